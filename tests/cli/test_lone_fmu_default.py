"""``--isolate``'s default: the guardian for a lone FMU, a process per FMU otherwise.

A run of one FMU (``fmionnx run model.fmu`` or a system of one FMU component) runs under the
guardian unless ``--isolate``, ``--sandbox`` or ``--record`` say otherwise; a crash or a hang
of the lone FMU still ends with every completed step written, a fault naming the component
and the time, and exit status 1. ``run.json`` and the run's first line say what was chosen.
"""

from __future__ import annotations

import json
import re
import threading
from pathlib import Path
from typing import Any

import pytest

import fmionnx
from fmionnx.backends.inprocess import InProcessBackend, InProcessOptions
from fmionnx.results.csvfile import read_csv
from fmionnx.runtime.backend import OptionsError, RunContext
from tests.backends.test_isolation import HANG, SEGFAULT, _cli, _finish
from tests.conftest import build_fixture_fmu


def _execution(out: Path) -> dict[str, Any]:
    info: dict[str, Any] = json.loads((out / "run.json").read_text(encoding="utf-8"))
    return info


def _run(args: list[str], tmp_path: Path, timeout: float = 60) -> tuple[int, str]:
    return _finish(_cli(["run", *args], tmp_path / "tmp"), timeout=timeout)


def _one_component_system(tmp_path: Path, *, with_signal: bool) -> Path:
    signal = "\n  src: {kind: signal, outputs: {u: {constant: 1}}}" if with_signal else ""
    connections = "\nconnections:\n  - src.u -> integ.u" if with_signal else ""
    path = tmp_path / "system.yaml"
    path.write_text(
        f"""fmionnx: 1
name: lone
run: {{stop: 1, step: 0.01}}
components:
  integ: {{kind: fmu, path: {build_fixture_fmu("Integrator")}}}{signal}{connections}
""",
        encoding="utf-8",
    )
    return path


def test_a_lone_fmu_runs_under_the_guardian_by_default(tmp_path: Path) -> None:
    out = tmp_path / "out"
    fmu = build_fixture_fmu("Integrator")
    code, output = _run([str(fmu), "--stop-time", "1", "-p", "u=1", "--out", str(out)], tmp_path)
    assert code == 0, output
    assert "from 0 to 1 s in a guarded process, the default for a lone FMU ..." in output
    info = _execution(out)
    assert info["execution"]["isolate"] == "guardian"
    assert info["execution"]["isolate_default"] is True
    assert read_csv(out / "results.csv")["x"][-1] == pytest.approx(1.0)
    assert list((tmp_path / "tmp").iterdir()) == []


@pytest.mark.parametrize(("with_signal", "expected"), [(False, "guardian"), (True, "fmus")])
def test_a_system_file_of_one_fmu_is_guarded_and_of_two_components_is_not(
    tmp_path: Path, with_signal: bool, expected: str
) -> None:
    out = tmp_path / "out"
    system = _one_component_system(tmp_path, with_signal=with_signal)
    code, output = _run([str(system), "-q", "--out", str(out)], tmp_path)
    assert code == 0, output
    assert _execution(out)["execution"]["isolate"] == expected
    assert _execution(out)["execution"]["isolate_default"] is True


@pytest.mark.parametrize(
    ("words", "expected"),
    [(["--isolate", "none"], "none"), (["--isolate", "fmus"], "fmus"), (["--record"], "fmus")],
)
def test_an_explicit_word_or_record_keeps_its_isolation(
    tmp_path: Path, words: list[str], expected: str
) -> None:
    out = tmp_path / "out"
    fmu = build_fixture_fmu("Integrator")
    if words == ["--record"]:
        words = ["--record", str(tmp_path / "run.mcap")]
    code, output = _run([str(fmu), "-q", "--stop-time", "0.5", "--out", str(out), *words], tmp_path)
    assert code == 0, output
    execution = _execution(out)["execution"]
    assert execution["isolate"] == expected
    assert execution["isolate_default"] is (words[0] == "--record")


@pytest.mark.parametrize(
    ("isolate", "expected"),
    [
        ("none,fmus", "--isolate `none` stands alone: it cannot be given with `fmus`"),
        (["guardian", "all"], "--isolate `guardian` stands alone: it cannot be given with `all`"),
        ("integ,none,integ", "--isolate `none` stands alone: it cannot be given with `integ`"),
    ],
)
def test_none_and_guardian_stand_alone(isolate: str | list[str], expected: str) -> None:
    """A bug hunt: ``--isolate none,fmus`` ran (which won?) and run.json recorded the words."""
    with pytest.raises(OptionsError) as refused:
        InProcessOptions.checked({"isolate": isolate})
    assert str(refused.value) == expected
    assert InProcessOptions.checked({"isolate": "none,none"}).words == ("none", "none")


def _resolved(options: InProcessOptions, system: Any, *, record: bool) -> InProcessOptions:
    chosen = InProcessBackend().prepare(system, options, RunContext(recording=record))
    assert isinstance(chosen, InProcessOptions)
    return chosen


@pytest.fixture
def only_main_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """This process as the CLI's is when it chooses: no other thread (tests run beside
    threads that earlier tests' libraries left)."""
    monkeypatch.setattr(threading, "enumerate", lambda: [threading.main_thread()])


def test_the_default_is_chosen_from_the_compiled_system(only_main_thread: None) -> None:
    lone = fmionnx.load(build_fixture_fmu("Integrator")).compiled
    chosen = _resolved(InProcessOptions(), lone, record=False)
    assert (chosen.isolate, chosen.isolate_default, chosen.guarded) == (("guardian",), True, True)
    assert _resolved(InProcessOptions(), lone, record=True).isolate == ("fmus",)
    assert _resolved(InProcessOptions(sandbox=True), lone, record=False).isolate == ("fmus",)
    explicit = _resolved(InProcessOptions(isolate=("none",)), lone, record=False)
    assert (explicit.isolate, explicit.isolate_default) == (("none",), False)
    assert InProcessOptions().words == ("fmus",)  # before the system is known


def test_the_guardian_is_not_the_default_where_a_fork_is_not_safe(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Another Python thread could hold a lock at the fork (a notebook's): FMUs get a
    process each instead, which isolates as well without forking the caller. fmionnx's own
    watch thread does not count: a forked child makes its own."""
    from fmionnx.runtime import watchdog

    lone = fmionnx.load(build_fixture_fmu("Integrator")).compiled
    other = threading.Thread(target=lambda: None)
    watch = threading.Thread(target=lambda: None)
    monkeypatch.setattr(watchdog, "watch_thread", lambda: watch)
    monkeypatch.setattr(threading, "enumerate", lambda: [threading.main_thread(), other])
    assert _resolved(InProcessOptions(), lone, record=False).isolate == ("fmus",)
    monkeypatch.setattr(threading, "enumerate", lambda: [threading.main_thread(), watch])
    assert _resolved(InProcessOptions(), lone, record=False).isolate == ("guardian",)


def test_a_crash_of_a_lone_fmu_under_the_default_keeps_every_completed_step(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    fmu = build_fixture_fmu("Faulty")
    args = [str(fmu), "--stop-time", "1", "--step", "0.01", "-p", f"mode={SEGFAULT}"]
    code, output = _run([*args, "-p", "failAt=0.3", "--out", str(out)], tmp_path)
    assert code == 1, output
    crashed = (
        r"fault: component `Faulty\w*` at t=0.3 s: the model crashed with SIGSEGV during its "
        r"step, in fmi2DoStep or the calls that set its inputs and get its outputs"
    )
    assert re.search(crashed, output), output
    assert output.rstrip().endswith(f"Results: {out}")
    table = read_csv(out / "results.csv")
    assert len(table["time"]) == 31  # 0 .. 0.3: every completed step
    assert table["time"][-1] == pytest.approx(0.3)
    info = _execution(out)
    assert info["status"] == "fault"
    assert info["error"]["component"].startswith("Faulty")
    assert info["error"]["time"] == pytest.approx(0.3)
    assert info["execution"]["isolate"] == "guardian"
    assert list((tmp_path / "tmp").iterdir()) == []


def test_a_crash_under_an_explicit_isolate_fmus_names_the_fmi_function(tmp_path: Path) -> None:
    out = tmp_path / "out"
    fmu = build_fixture_fmu("Faulty")
    args = [str(fmu), "-q", "--stop-time", "1", "--step", "0.01", "-p", f"mode={SEGFAULT}"]
    args += ["-p", "failAt=0.3"]
    code, output = _run([*args, "--out", str(out), "--isolate", "fmus"], tmp_path)
    assert code == 1, output
    assert "at t=0.3 s: the model crashed with SIGSEGV in fmi2DoStep" in output, output
    assert len(read_csv(out / "results.csv")["time"]) == 31


def test_a_hang_of_a_lone_fmu_under_the_default_is_abandoned_with_its_results(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    fmu = build_fixture_fmu("Faulty")
    args = [str(fmu), "--stop-time", "1", "--step", "0.01", "-p", f"mode={HANG}"]
    args += ["-p", "failAt=0.3"]
    code, output = _run([*args, "--out", str(out), "--step-timeout", "1"], tmp_path)
    assert code == 1, output
    hung = r"component `Faulty\w*` at t=0.3 s: a step did not return within 1 s"
    assert re.search(hung, output), output
    assert output.count("Results:") == 1  # written once, by the guarded process
    info = _execution(out)
    assert info["status"] == "fault"
    assert info["execution"]["isolate"] == "guardian"
    assert len(read_csv(out / "results.csv")["time"]) == 31
    assert list((tmp_path / "tmp").iterdir()) == []


def test_the_default_writes_the_bytes_of_an_unguarded_run(tmp_path: Path) -> None:
    fmu = build_fixture_fmu("Integrator")
    args = [str(fmu), "-q", "--stop-time", "300", "--step", "0.01", "-p", "u=0.3"]
    files = {}
    for mode in ("default", "none"):
        out = tmp_path / mode
        chosen = [] if mode == "default" else ["--isolate", "none"]
        code, output = _run([*args, "--out", str(out), *chosen], tmp_path)
        assert code == 0, output
        files[mode] = (out / "results.csv").read_bytes()
    assert _execution(tmp_path / "default")["execution"]["isolate"] == "guardian"
    assert files["default"] == files["none"]
    assert files["default"].count(b"\n") == 30_002  # the header, the start and every step
