"""The compile cache: an unchanged system is read back, not compiled; anything it was made from
that changes makes it compile again; an entry that is not sound is refused, never used."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.core.private import KEY_FILE
from fmionnx.pipeline import compilecache, system
from fmionnx.pipeline.system import CompileResult, compile_system
from tests.conftest import REPO, build_fixture_fmu, let_files_settle

SYSTEM = """\
fmionnx: 1
name: cached
run: {stop: 0.5, step: 0.01}
components:
  gain: {kind: fmu, path: Gain.fmu, parameters: {k: 3}}
  integrator: {kind: fmu, path: Integrator.fmu}
  lonely: {kind: signal, outputs: {y: {sine: {amplitude: 1, frequency: 2}}}}
connections:
  - gain.y -> integrator.u
record: [integrator.x, gain.y, lonely.y]
"""


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A system of two fixture FMUs and a signal (unconnected: warning W050), run from its
    own folder; the cache in ``tmp_path / cache``."""
    return system_folder(tmp_path, monkeypatch)


def system_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, also: dict[str, str] | None = None
) -> Path:
    """:func:`folder`'s making, with more text files ``also`` (name -> text) beside."""
    here = tmp_path / "system"
    here.mkdir()
    for name in ("Gain", "Integrator"):
        shutil.copy(build_fixture_fmu(name), here / f"{name}.fmu")
    for name, text in {"system.yaml": SYSTEM, **(also or {})}.items():
        (here / name).write_text(text, encoding="utf-8")
    let_files_settle()
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(here)
    return here


@pytest.fixture
def compiles(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """Every real compile of a system file in this process."""
    seen: list[Path] = []
    real = system._compile_system

    def counting(path: Path, flags: object) -> CompileResult:
        seen.append(path)
        return real(path, flags)  # type: ignore[arg-type]

    monkeypatch.setattr(system, "_compile_system", counting)
    return seen


def entries(tmp_path: Path) -> list[Path]:
    root = tmp_path / "cache" / "compiled"
    return sorted(p / compilecache.ENTRY for p in root.iterdir() if not p.name.startswith("."))


def test_an_unchanged_system_is_read_back_equal_with_its_warnings(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    first = compile_system("system.yaml")
    second = compile_system("system.yaml")
    assert len(compiles) == 1
    assert second.system == first.system
    assert second.diagnostics == first.diagnostics
    assert [d.code for d in second.diagnostics] == ["W030", "W050"]
    assert len(entries(tmp_path)) == 1


def test_results_are_the_same_with_and_without_the_cache(
    folder: Path, compiles: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    assert_same_results_off_missed_and_hit("system.yaml", compiles, monkeypatch)


def assert_same_results_off_missed_and_hit(
    target: str, compiles: list[Path], monkeypatch: pytest.MonkeyPatch, **options: Any
) -> None:
    """Run ``target`` with the cache off, then on twice (a miss, a hit): one compile fewer,
    the same ``results.csv`` bytes and the same ``run.json`` but for its timings."""
    outs = []
    for name, setting in (("off", "0"), ("miss", "1"), ("hit", "1")):
        monkeypatch.setenv(compilecache.SWITCH, setting)
        fmionnx.run(target, out=Path(name), isolate="none", **options)
        outs.append(Path(name))
    assert len(compiles) == 2  # off and the miss compiled; the hit did not
    reference = (outs[0] / "results.csv").read_bytes()
    assert all((out / "results.csv").read_bytes() == reference for out in outs)
    runs = [json.loads((out / "run.json").read_text(encoding="utf-8")) for out in outs]
    for run in runs:  # what differs between any two runs: how long they took
        del run["wall_time"], run["real_time_factor"]
    assert runs[1] == runs[0]
    assert runs[2] == runs[0]


def test_validate_prints_the_same_report_from_the_cache(folder: Path, tmp_path: Path) -> None:
    def validate(*args: str) -> tuple[int, str]:
        done = subprocess.run(
            [sys.executable, "-m", "fmionnx", "validate", "system.yaml", *args],
            capture_output=True, text=True, check=False, timeout=120,
        )  # fmt: skip
        return done.returncode, done.stdout

    for args in ((), ("--format", "json")):
        miss = validate(*args)
        hit = validate(*args)
        assert hit == miss
        assert "W050" in hit[1]
    assert len(entries(tmp_path)) == 1


PROBE = """\
import json, sys
from fmionnx.cli import main
sys.argv = ["fmionnx", "validate", "system.yaml"]
try:
    main()
except SystemExit:
    pass
print(json.dumps(sorted(sys.modules)), file=sys.stderr)
"""


def test_a_hit_reads_no_system_file_and_no_model(folder: Path) -> None:
    """Neither the YAML front end and the compiler nor the libraries that read models."""
    (folder / "probe.py").write_text(PROBE, encoding="utf-8")

    def loaded() -> set[str]:
        done = subprocess.run(
            [sys.executable, "probe.py"], capture_output=True, text=True, check=True, timeout=120
        )
        return set(json.loads(done.stderr.strip().splitlines()[-1]))

    miss, hit = loaded(), loaded()
    compiling = {"fmionnx.spec.yaml", "fmionnx.compile.compiler", "fmpy", "ruamel.yaml"}
    assert compiling <= miss
    assert hit & (compiling | {"numpy", "networkx", "lxml", "rosbags"}) == set()


@pytest.mark.parametrize(
    "change",
    [
        pytest.param(lambda f: f.joinpath("system.yaml").write_text(SYSTEM.replace("k: 3", "k: 4")), id="system"),
        pytest.param(lambda f: shutil.copy(build_fixture_fmu("Vector3"), f / "Gain.fmu"), id="model"),
        pytest.param(lambda f: f.joinpath("Gain.path.csv").write_text("x,y\n0,0\n1,1\n"), id="path-file-appears"),
    ],
)  # fmt: skip
def test_a_change_to_what_it_was_compiled_from_compiles_again(
    folder: Path, compiles: list[Path], change: Callable[[Path], object]
) -> None:
    compile_system("system.yaml")
    change(folder)
    compile_system("system.yaml")
    assert len(compiles) == 2


def test_the_same_file_from_another_folder_or_with_flags_is_another_entry(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    from fmionnx.compile.runflags import RunFlags

    compile_system("system.yaml")
    compile_system(folder / "system.yaml")  # paths in diagnostics and the system differ
    compile_system("system.yaml", RunFlags(step=0.05))
    compile_system("system.yaml", RunFlags(step=0.05))
    assert len(compiles) == 3
    assert len(entries(tmp_path)) == 3


def test_a_system_with_errors_is_never_kept(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    (folder / "system.yaml").write_text(SYSTEM.replace("gain.y ->", "gain.nope ->"))
    assert not compile_system("system.yaml").ok
    assert not compile_system("system.yaml").ok
    assert len(compiles) == 2
    assert not (tmp_path / "cache" / "compiled").exists() or entries(tmp_path) == []


def test_switched_off_it_neither_reads_nor_writes(
    folder: Path, compiles: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(compilecache.SWITCH, "0")
    compile_system("system.yaml")
    compile_system("system.yaml")
    assert len(compiles) == 2
    # its own folder only: the models' kept answers have switches of their own (running.md)
    assert not (tmp_path / "cache" / "compiled").exists()


# -- refused entries ----------------------------------------------------------------------------


def _tamper_body(entry: Path) -> None:
    """Drop a warning and a recorded signal inside the entry (neither is covered by the
    compiled system's content hash), keeping the now wrong signature."""
    signature, _, body = entry.read_bytes().partition(b"\n")
    data = json.loads(body)
    data["diagnostics"] = data["diagnostics"][:1]
    system = json.loads(data["system"])
    system["system"]["record"] = system["system"]["record"][:1]
    data["system"] = json.dumps(system)
    entry.write_bytes(signature + b"\n" + json.dumps(data).encode())


def _forge_with_a_new_key(entry: Path) -> None:
    """Sign a tampered entry with a key of the forger's own, put in place of the user's."""
    import hashlib
    import hmac

    _tamper_body(entry)
    key = entry.parent.parent / KEY_FILE
    key.unlink()
    key.write_bytes(b"k" * 32)
    key.chmod(0o644)  # readable by others: a key anyone could have used
    _, _, body = entry.read_bytes().partition(b"\n")
    entry.write_bytes(hmac.new(b"k" * 32, body, hashlib.sha256).hexdigest().encode() + b"\n" + body)


def _truncate(entry: Path) -> None:
    entry.write_bytes(entry.read_bytes()[:100])


def _group_writable(entry: Path) -> None:
    entry.chmod(0o664)


def _folder_writable_by_others(entry: Path) -> None:
    entry.parent.chmod(0o777)


def _a_link(entry: Path) -> None:
    elsewhere = entry.with_name("elsewhere.json")
    entry.rename(elsewhere)
    entry.symlink_to(elsewhere)


def _another_owner(entry: Path) -> None:
    os.chown(entry, 65534, 65534)


def resign(entry: Path, change: Callable[[dict[str, object]], None]) -> None:
    """Change the entry's data and sign it with the user's real key (as a bug would)."""
    import hashlib
    import hmac

    data = json.loads(entry.read_bytes().partition(b"\n")[2])
    change(data)
    secret = (entry.parent.parent / KEY_FILE).read_bytes()
    body = json.dumps(data).encode()
    entry.write_bytes(hmac.new(secret, body, hashlib.sha256).hexdigest().encode() + b"\n" + body)


def _moved_from_another_key(entry: Path) -> None:
    """A sound entry written for another key (another system), found under this one's."""
    resign(entry, lambda data: data.update(key="1" * 64))


TAMPERING = [_tamper_body, _forge_with_a_new_key, _truncate, _group_writable]
TAMPERING += [_folder_writable_by_others, _a_link, _moved_from_another_key]
if os.getuid() == 0:  # only root can give a file to another user
    TAMPERING.append(_another_owner)


@pytest.mark.parametrize("tamper", TAMPERING, ids=lambda f: f.__name__.strip("_"))
def test_an_entry_that_is_not_sound_is_refused_and_written_again(
    folder: Path, compiles: list[Path], tmp_path: Path, tamper: Callable[[Path], None]
) -> None:
    first = compile_system("system.yaml")
    (entry,) = entries(tmp_path)
    tamper(entry)
    again = compile_system("system.yaml")
    assert len(compiles) == 2  # not believed: compiled again
    assert again.system == first.system
    assert again.diagnostics == first.diagnostics
    compile_system("system.yaml")
    assert len(compiles) == 2  # and written again, soundly: the next compile is a hit


def test_an_entry_naming_a_model_no_lookup_hashed_is_refused(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    """Even correctly signed (a bug, or a key that leaked): the system may only run models
    whose contents the lookup just checked."""

    def forget_gain(data: dict[str, object]) -> None:
        listed = data["dependencies"]
        assert isinstance(listed, list)
        data["dependencies"] = [d for d in listed if not d[0].endswith("Gain.fmu")]

    compile_system("system.yaml")
    (entry,) = entries(tmp_path)
    resign(entry, forget_gain)
    compile_system("system.yaml")
    assert len(compiles) == 2


def test_the_cache_is_bounded(
    folder: Path, compiles: list[Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Beyond its size limit the least recently used entries go (the one just written and
    entries used in the last minutes are kept, as for the SSP cache: see cachedir)."""
    import time

    for k in range(3):
        (folder / "system.yaml").write_text(SYSTEM.replace("k: 3", f"k: {k + 10}"))
        let_files_settle()
        compile_system("system.yaml")
    old = time.time() - 3600
    for entry in entries(tmp_path):
        os.utime(entry.parent, (old, old))
    monkeypatch.setenv("FMIONNX_COMPILE_CACHE_MAX_BYTES", "1")
    (folder / "system.yaml").write_text(SYSTEM)
    let_files_settle()
    compile_system("system.yaml")
    assert len(entries(tmp_path)) == 1  # only the newest: the others were over the bound


def test_the_reference_system_reads_back_equal(compiles: list[Path]) -> None:
    """The whole IR of the reference scenario (scene map, expected path, checks, the ROS 2
    plan) survives the entry's round trip; and it is kept (its FMUs' and ONNX model's hashes
    are those their interfaces were read from)."""
    from tests.conftest import built_model

    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    path = REPO / "systems" / "sign_follower.yaml"
    first = compile_system(path)
    second = compile_system(path)
    assert first.ok
    assert len(compiles) == 1
    assert second.system == first.system
    assert second.diagnostics == first.diagnostics


@pytest.mark.parametrize(
    ("command", "message"),
    [
        (
            ["validate", "pipe.yaml"],
            "`pipe.yaml` is a directory or special file, not a system file",
        ),
        (["run", "pipe.yaml"], "`pipe.yaml` is a directory or special file, not a system file"),
        (["sweep", "pipe.yaml", "--out", "o"], "study file `pipe.yaml` is not a file"),
    ],
    ids=["validate", "run", "sweep"],
)
def test_a_fifo_named_like_a_system_file_is_refused_not_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: list[str], message: str
) -> None:
    """The cache's key reads a file's bytes before the front end looks at it: never a read
    that waits for a writer that never comes."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    os.mkfifo(tmp_path / "pipe.yaml")
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", *command],
        capture_output=True, text=True, check=False, timeout=60,
    )  # fmt: skip
    assert done.returncode == 1
    assert message in " ".join(done.stdout.split() + done.stderr.split())
    assert not (tmp_path / "o").exists()
