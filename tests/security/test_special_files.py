"""A FIFO or a device where fmionnx expects a file never hangs a command (E011).

Opening a FIFO for reading waits for a writer for ever, and reading ``/dev/zero`` never
ends; neither can be interrupted with Ctrl-C while it waits in the kernel. Every read of a
file someone else named goes through :mod:`fmionnx.core.regularfile`, which looks at the
file before it opens it. Each command runs in a child process with a deadline, so that a
broken protection fails its test instead of hanging the suite.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fmionnx.compile.systemfile import CompiledFileError, read_compiled
from tests.security import hostile

#: Seconds a refusal may take (it takes a second or two: the interpreter's start).
DEADLINE = 60


def _fmionnx(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fmionnx", *map(str, args)],
        capture_output=True, text=True, timeout=DEADLINE, check=False, cwd=cwd,
    )  # fmt: skip


def _special(path: Path, kind: str) -> Path:
    """``path`` made a FIFO, or a link to ``/dev/zero``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    return path


def test_a_scene_include_that_is_a_fifo_is_e011(tmp_path: Path) -> None:
    scene = tmp_path / "scene.xml"
    scene.write_text(
        '<mujoco><include file="part.xml"/><worldbody><geom size="1"/></worldbody></mujoco>',
        "utf-8",
    )
    _special(tmp_path / "part.xml", "fifo")
    done = _fmionnx("validate", scene, cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "error[E011 not-a-file]: the scene file `part.xml` is a FIFO (named pipe)" in (
        done.stdout
    )


@pytest.mark.parametrize("element", ["mesh", "hfield", "texture"])
def test_a_file_a_scene_names_that_is_a_fifo_is_e011(tmp_path: Path, element: str) -> None:
    asset = {
        "mesh": '<mesh name="a" file="a.stl"/>',
        "hfield": '<hfield name="a" file="a.stl" size="1 1 1 1"/>',
        "texture": '<texture name="a" type="2d" file="a.stl"/>',
    }[element]
    scene = hostile.scene(
        tmp_path / "scene.xml", f'<asset>{asset}</asset><worldbody><geom size="1"/></worldbody>'
    )
    _special(tmp_path / "a.stl", "fifo")
    done = _fmionnx("validate", scene, cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert f"`a.stl` (the file of `<{element}>` at `scene.xml:1`) is a FIFO" in done.stdout


@pytest.mark.parametrize("kind", ["fifo", "dev-zero"])
def test_a_compiled_system_file_that_is_not_a_regular_file_is_refused_unread(
    tmp_path: Path, kind: str
) -> None:
    path = _special(tmp_path / "system.fmionnx.json", kind)
    with pytest.raises(CompiledFileError, match="not a regular file"):
        read_compiled(path)
    done = _fmionnx("node", path, "x", cwd=tmp_path)
    assert done.returncode != 0
    assert "not a regular file" in done.stdout + done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("kind", ["fifo", "dev-zero"])
def test_an_ssp_archive_that_is_not_a_regular_file_is_e011(tmp_path: Path, kind: str) -> None:
    path = _special(tmp_path / "system.ssp", kind)
    done = _fmionnx("validate", path, cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "error[E011 not-a-file]: `system.ssp`: the archive `system.ssp` is" in done.stdout


def test_a_parameter_file_of_an_ssd_that_is_a_fifo_ends_in_a_diagnostic(tmp_path: Path) -> None:
    (tmp_path / "SystemStructure.ssd").write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<ssd:SystemStructureDescription version="1.0" name="s"\n'
        '  xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription"\n'
        '  xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon">\n'
        '  <ssd:System name="s">\n'
        '    <ssd:ParameterBindings><ssd:ParameterBinding source="values.ssv"/>'
        "</ssd:ParameterBindings>\n"
        "  </ssd:System>\n"
        "</ssd:SystemStructureDescription>\n",
        "utf-8",
    )
    _special(tmp_path / "values.ssv", "fifo")
    done = _fmionnx("validate", tmp_path / "SystemStructure.ssd", cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "values.ssv" in done.stdout
    assert "Traceback" not in done.stderr


def test_onnx_external_data_in_a_fifo_is_e011(tmp_path: Path) -> None:
    path = hostile.external_initializer(tmp_path / "model" / "small.onnx", 1)
    (path.parent / "w.bin").unlink()
    _special(path.parent / "w.bin", "fifo")
    done = _fmionnx("validate", path, cwd=tmp_path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "error[E011 not-a-file]: `w.bin`, the data of tensor `w`, is a FIFO" in done.stdout


LOOKING = """
import os, sys
from pathlib import Path
from fmionnx.compile.systemfile import written_by_fmionnx
from fmionnx.core.owned import MARKER, OwnedFolder
from fmionnx.pipeline import compilecache

here = Path(sys.argv[1])
before = len(os.listdir("/proc/self/fd"))
for _ in range(5):
    assert compilecache.slot(here / "system.yaml", None) is None
    assert not written_by_fmionnx(here / "out.fmionnx.json")
    assert not OwnedFolder(here / "out").claimed()
print("descriptors", before, len(os.listdir("/proc/self/fd")))
"""


@pytest.mark.parametrize("kind", ["folder", "fifo", "device"])
def test_what_only_looks_at_a_file_passes_over_a_special_one_and_keeps_no_descriptor(
    tmp_path: Path, kind: str
) -> None:
    """A cache's key, the test for a compiled system of ours and the ownership record of an
    output folder look at a file without being told it is one: a folder, a FIFO or a device
    so named is not what they look for (never a read that waits, never a traceback), and
    the descriptor they opened is closed again."""
    from fmionnx.core.owned import MARKER

    for name in ("system.yaml", "out.fmionnx.json", f"out/{MARKER}"):
        path = tmp_path / name
        if kind == "folder":
            path.mkdir(parents=True)
        else:
            _special(path, kind)
    done = subprocess.run(
        [sys.executable, "-c", LOOKING, str(tmp_path)],
        capture_output=True, text=True, timeout=DEADLINE, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    _, before, after = done.stdout.split()
    assert after == before
