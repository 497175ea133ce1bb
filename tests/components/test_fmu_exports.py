"""E024: a shared library that lacks a function its interface type needs is named, not loaded.

The libraries are real: ``Scale3`` rebuilt without its refused stubs (``SCALE3_OMIT_STUBS``), or
as a build that ignores the standard's prefix rule would make it (``SCALE3_AS_STATIC_SOURCE``:
every name prefixed). The symbols are read from the ELF file, never ``dlopen``-ed.
"""

from __future__ import annotations

import random
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.kinds.fmu.build import build_fmu
from fmionnx.kinds.fmu.elfsymbols import NotElfError, exported_symbols
from fmionnx.kinds.fmu.exports import REQUIRED
from tests.conftest import FIXTURES

SCALE3 = FIXTURES / "fmus" / "Scale3"

SYSTEM = """\
fmionnx: 1
name: scale
run: {stop: 0.02, step: 0.01}
components:
  s: {kind: fmu, path: Scale3.fmu, parameters: {u: 1.0}}
"""


def _variant(tmp_path: Path, definition: str) -> Path:
    """Scale3 built with one more preprocessor definition, in ``tmp_path/Scale3.fmu``."""
    source = tmp_path / "src"
    shutil.copytree(SCALE3, source)
    build = source / "sources" / "buildDescription.xml"
    build.write_text(
        build.read_text().replace(
            '<IncludeDirectory name="include"/>',
            f'<IncludeDirectory name="include"/>\n      <PreprocessorDefinition name="{definition}"/>',
        )
    )
    return build_fmu(source, tmp_path / "Scale3.fmu")


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def test_missing_functions_are_named_before_the_run(tmp_path: Path) -> None:
    _variant(tmp_path, "SCALE3_OMIT_STUBS")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    code, output = _cli("run", str(tmp_path / "system.yaml"), "--out", str(tmp_path / "out"))
    assert code == 1
    assert "E024" in output
    assert "`fmi3GetFloat32`" in output
    assert "more" in output
    assert "prefixed with" not in output
    assert "`fmi3DoStep`" not in output  # it is there
    assert "undefined symbol" not in output
    assert "Traceback" not in output


def test_a_prefixed_library_is_e024_in_validate(tmp_path: Path) -> None:
    fmu = _variant(tmp_path, "SCALE3_AS_STATIC_SOURCE")
    code, output = _cli("validate", str(fmu))
    assert code == 1
    assert "E024" in output
    assert "`fmi3GetVersion`" in output
    assert "E019" not in output  # its aliases are no FMPy finding (see validation.py)
    assert "prefixed with `Scale3_`" in output
    assert "more" in output  # every required name is missing; a dozen are quoted


def test_required_functions_follow_the_standard() -> None:
    assert "fmi2DoStep" in REQUIRED[2, "cs"]
    assert "fmi2DoStep" not in REQUIRED[2, "me"]
    assert "fmi2GetDerivatives" in REQUIRED[2, "me"]
    assert set(REQUIRED[3, "cs"]) == set(REQUIRED[3, "me"])  # the loader binds the whole API
    assert len(set(REQUIRED[3, "cs"])) == len(REQUIRED[3, "cs"])


@pytest.mark.parametrize(
    "data",
    [
        b"",
        b"MZ\x90\x00",
        b"\x7fELF",
        b"\x7fELF\x02\x01\x01" + b"\0" * 9,
        b"\x7fELF\x02\x01\x01" + b"\0" * 33 + b"\xff" * 30,
        b"\x7fELF\x03\x01\x01" + b"\0" * 80,
    ],
)
def test_damaged_elf_files_are_not_elf(data: bytes) -> None:
    with pytest.raises(NotElfError):
        exported_symbols(data)


def test_damaged_libraries_never_raise_anything_else(fixture_fmu: Callable[[str], Path]) -> None:
    """Truncated and randomly corrupted copies of a real library: symbols or NotElfError."""
    data = zipfile.ZipFile(fixture_fmu("Scale3")).read("binaries/x86_64-linux/Scale3.so")
    assert "fmi3DoStep" in exported_symbols(data)
    damaged = [data[:cut] for cut in (16, 64, 100, len(data) // 2, len(data) - 1)]
    rng = random.Random(13)
    for _ in range(300):
        copy = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            at = rng.randrange(0, 128) if rng.random() < 0.5 else rng.randrange(len(copy))
            copy[at] = rng.randrange(256)
        damaged.append(bytes(copy))
    for sample in damaged:
        try:
            names = exported_symbols(sample)
        except NotElfError:
            continue
        assert isinstance(names, frozenset)
