"""A study's compile kept in the compile cache: an unchanged study is read back, not compiled;
a change to the study file, its system file or a model compiles it again; a study with
errors, or one whose files changed during its compile, is never kept; an entry whose plan
does not decode is refused."""

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

from fmionnx.compile import study as study_compiler
from fmionnx.core.errors import DiagnosticError
from fmionnx.pipeline import compilecache
from fmionnx.pipeline.sweep import plan_study
from fmionnx.pipeline.system import check_study
from tests.conftest import build_fixture_fmu, let_files_settle
from tests.pipeline.test_compile_cache import SYSTEM, resign, system_folder

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
timeout: 30
parameters:
  gain.k: [0.5, 1, 2]
  run.stop: [0.3]
metrics:
  end: final(integrator.x)
  peak: max(gain.y)
objective: {minimize: peak}
"""


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A study of the compile cache tests' system (two fixture FMUs, a signal: warnings W030
    and W050), run from its folder; the cache in ``tmp_path / cache``."""
    return system_folder(tmp_path, monkeypatch, {"study.yaml": STUDY})


@pytest.fixture
def compiles(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """Every real compile of a study file in this process."""
    seen: list[Path] = []
    real = study_compiler.compile_study

    def counting(loaded: Any, *args: Any, **kwargs: Any) -> Any:
        seen.append(loaded.path)
        return real(loaded, *args, **kwargs)

    monkeypatch.setattr(study_compiler, "compile_study", counting)
    return seen


def study_entries(tmp_path: Path) -> list[Path]:
    """The cache's entries that hold a study's plan (its system has an entry of its own)."""
    root = tmp_path / "cache" / "compiled"
    found = [p / compilecache.ENTRY for p in root.iterdir() if not p.name.startswith(".")]
    return [e for e in found if b'"payload":{' in e.read_bytes()]


def test_an_unchanged_study_is_read_back_equal_with_its_warnings(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    first, warned = plan_study("study.yaml")
    second, warned_again = plan_study("study.yaml")
    assert len(compiles) == 1
    assert second == first
    assert repr(second) == repr(first)  # 0.3 stays a float, 1 an int: the same table
    assert second.fingerprint == first.fingerprint  # --resume accepts either's folder
    assert warned_again == warned
    assert [d.code for d in warned] == ["W030", "W050"]
    assert [m.name for m in second.metrics] == ["end", "peak"]
    assert second.objective is not None
    assert second.objective.metric == "peak"
    assert (second.isolate, second.timeout) == (("none",), 30.0)
    assert len(study_entries(tmp_path)) == 1


@pytest.mark.parametrize(
    "change",
    [
        pytest.param(lambda f: f.joinpath("study.yaml").write_text(STUDY.replace("2]", "3]")), id="study"),
        pytest.param(lambda f: f.joinpath("system.yaml").write_text(SYSTEM.replace("k: 3", "k: 4")), id="system"),
        pytest.param(lambda f: shutil.copy(build_fixture_fmu("Vector3"), f / "Gain.fmu"), id="model"),
    ],
)  # fmt: skip
def test_a_change_to_what_it_was_compiled_from_compiles_it_again(
    folder: Path, compiles: list[Path], change: Callable[[Path], object]
) -> None:
    first, _ = plan_study("study.yaml")
    change(folder)
    let_files_settle()
    try:
        again, _ = plan_study("study.yaml")
    except DiagnosticError:  # the Vector3 model has no `k`: an error, found by compiling
        again = None
    assert len(compiles) == 2
    assert again != first


def test_a_study_with_errors_is_never_kept(
    folder: Path, compiles: list[Path], tmp_path: Path
) -> None:
    (folder / "study.yaml").write_text(STUDY.replace("max(gain.y)", "max(gain.nope)"))
    for _ in range(2):
        with pytest.raises(DiagnosticError, match="nope"):
            plan_study("study.yaml")
    assert len(compiles) == 2
    assert study_entries(tmp_path) == []


def test_a_system_file_edited_during_the_study_compile_is_not_kept(
    folder: Path, compiles: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The plan would be kept with a system file hash it was not made from."""
    counting = study_compiler.compile_study

    def editing_once(*args: Any, **kwargs: Any) -> Any:
        plan = counting(*args, **kwargs)
        if len(compiles) == 1:
            (folder / "system.yaml").write_text(SYSTEM + "\n# edited\n")
        return plan

    monkeypatch.setattr(study_compiler, "compile_study", editing_once)
    plan_study("study.yaml")
    let_files_settle()
    plan_study("study.yaml")
    assert len(compiles) == 2  # compiled again, not read back
    plan_study("study.yaml")
    assert len(compiles) == 2  # kept by the compile that saw no change


def test_a_study_file_replaced_after_its_key_was_read_is_not_kept_under_that_key(
    folder: Path, compiles: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its key names the bytes read first; the compile read others: keeping that plan would
    serve it for the first bytes. The key is read before the compile's start is noted."""
    from fmionnx.spec import study as study_spec

    real = study_spec.load_study
    other = STUDY.replace("2]", "3]")

    def replaced_first(path: Path, *args: Any) -> Any:
        if not compiles:
            path.write_text(other)
        return real(path, *args)

    monkeypatch.setattr(study_spec, "load_study", replaced_first)
    made, _ = plan_study("study.yaml")
    assert [c.values()["gain.k"] for c in made.cases] == [0.5, 1, 3]  # what it read
    (folder / "study.yaml").write_text(STUDY)  # the first bytes again: the first key
    let_files_settle()
    again, _ = plan_study("study.yaml")
    assert len(compiles) == 2  # not read back from the entry of the other bytes
    assert [c.values()["gain.k"] for c in again.cases] == [0.5, 1, 2]


def _broken_cases(data: dict[str, Any]) -> None:
    data["payload"]["cases"] = [{"id": 7}]


def _missing_field(data: dict[str, Any]) -> None:
    del data["payload"]["metrics"]


def _no_payload(data: dict[str, Any]) -> None:
    data["payload"] = None


@pytest.mark.parametrize("damage", [_broken_cases, _missing_field, _no_payload])
def test_a_kept_plan_that_does_not_decode_is_compiled_again(
    folder: Path, compiles: list[Path], tmp_path: Path, damage: Callable[[dict[str, Any]], None]
) -> None:
    """Signed with the user's key (as a bug would write it), still not believed."""
    first, _ = plan_study("study.yaml")
    (entry,) = study_entries(tmp_path)
    resign(entry, damage)  # type: ignore[arg-type]
    again, _ = plan_study("study.yaml")
    assert len(compiles) == 2
    assert again == first
    plan_study("study.yaml")
    assert len(compiles) == 2  # and kept again, soundly


def test_validate_of_a_study_reads_its_check_back(folder: Path, compiles: list[Path]) -> None:
    fresh = check_study("study.yaml")
    kept = check_study("study.yaml")
    assert len(compiles) == 1
    assert kept == fresh
    assert [d.code for d in kept.diagnostics] == ["W030", "W050"]
    plan_study("study.yaml")  # the sweep reads the check's entry: one compile in all
    assert len(compiles) == 1


PROBE = """\
import json, sys
from fmionnx.cli import main
sys.argv = ["fmionnx", "validate", "study.yaml", *sys.argv[1:]]
try:
    main()
except SystemExit as exc:
    print("exit", exc.code)
print(json.dumps(sorted(sys.modules)), file=sys.stderr)
"""


def test_validate_prints_the_same_report_from_the_cache_and_loads_no_pydantic(
    folder: Path,
) -> None:
    """The study's pydantic types and the compiler are what a kept check saves."""
    (folder / "probe.py").write_text(PROBE, encoding="utf-8")

    def validate(*args: str) -> tuple[str, set[str]]:
        done = subprocess.run(
            [sys.executable, "probe.py", *args],
            capture_output=True, text=True, check=True, timeout=120,
        )  # fmt: skip
        return done.stdout, set(json.loads(done.stderr.strip().splitlines()[-1]))

    compiling = {"pydantic", "fmionnx.spec.study", "fmionnx.compile.study"}
    missed, modules = validate()
    assert compiling <= modules
    hit, modules = validate()
    assert modules & compiling == set()
    assert hit == missed
    assert "W050" in hit
    assert hit.splitlines()[-1] == "exit 0"
    fresh = subprocess.run(
        [sys.executable, "probe.py", "--format", "json"],
        capture_output=True, text=True, check=True, timeout=120,
        env={**os.environ, compilecache.SWITCH: "0"},
    )  # fmt: skip
    assert validate("--format", "json")[0] == fresh.stdout


def test_validate_looks_a_study_up_once_and_passes_a_system_file_on(
    folder: Path, compiles: list[Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A study not yet kept is checked after one lookup (a second would hash its models again);
    a system file is no study: ``validate`` compiles it as one."""
    from fmionnx.pipeline import keptstudy
    from fmionnx.pipeline.system import check_if_study

    lookups: list[object] = []
    real = keptstudy.kept_plan
    monkeypatch.setattr(keptstudy, "kept_plan", lambda place: lookups.append(place) or real(place))
    checked = check_if_study("study.yaml")
    assert checked is not None
    assert [d.code for d in checked.diagnostics] == ["W030", "W050"]
    assert (len(lookups), len(compiles)) == (1, 1)
    assert check_if_study("study.yaml") == checked  # read back
    assert (len(lookups), len(compiles)) == (2, 1)
    assert check_if_study("system.yaml") is None
