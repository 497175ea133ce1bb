"""Smoke tests: every benchmark runs on a tiny size and reports what it measured.

Behaviour only: which loops ran, that they computed the same thing, what the tables and the
JSON contain. Wall times are never asserted (they depend on the machine and its load).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest
from rich.console import Console

from benchmarks import chain, isolation, report, run, scenario, startup
from tests.conftest import built_model

TINY_STEPS = 20


@pytest.fixture(scope="module")
def gain(tmp_path_factory: pytest.TempPathFactory):
    with chain.built_gain(tmp_path_factory.mktemp("gain")) as built:
        yield built


def test_chain_system_file_compiles_to_n_fmus_connected_in_a_row(gain, tmp_path: Path) -> None:
    import fmionnx

    fmu, unzipped = gain
    path = tmp_path / "chain.yaml"
    path.write_text(chain.system_text(chain.Chain(fmu, unzipped, 4, TINY_STEPS)), encoding="utf-8")
    system = fmionnx.load(path).compiled
    assert [c.name for c in system.components] == ["g0", "g1", "g2", "g3"]
    assert [str(c) for c in system.connections] == ["g0.y -> g1.u", "g1.y -> g2.u", "g2.y -> g3.u"]


@pytest.mark.parametrize("n", [1, 3])
def test_every_applicable_loop_ends_with_the_tail_output_two_to_the_n(gain, n: int) -> None:
    fmu, unzipped = gain
    outcomes = chain.measure(chain.Chain(fmu, unzipped, n, TINY_STEPS), repeats=2)
    assert [o.contender for o in outcomes] == list(chain.CONTENDERS)
    for outcome in outcomes:
        if outcome.skipped is None:
            assert len(outcome.samples) == 2
            assert outcome.correct, (outcome.contender, [s.final for s in outcome.samples])
            assert all(s.steps >= TINY_STEPS - 1 for s in outcome.samples)
    ran = {o.contender for o in outcomes if o.skipped is None}
    assert {chain.FMIONNX, chain.FMPY_LOOP, chain.CTYPES_FLOOR} <= ran
    assert (chain.SIMULATE_FMU in ran) == (n == 1)


def test_libcosim_runs_here_or_says_why_not(gain) -> None:
    fmu, unzipped = gain
    (outcome,) = chain.measure(chain.Chain(fmu, unzipped, 2, TINY_STEPS), 1, [chain.LIBCOSIM])
    problem = chain.libcosim_problem()
    if problem is None:
        assert outcome.skipped is None
        assert outcome.correct
    else:
        assert outcome.skipped == problem


def _outcome(name: str, n: int, micros: float) -> chain.Outcome:
    sample = chain.Sample(micros * 1e-6 * 100, 100, chain.GAIN**n)
    return chain.Outcome(name, n, [sample], expected=chain.GAIN**n)


def test_rows_give_ratios_to_the_floor_and_to_fmionnx() -> None:
    outcomes = [
        _outcome(chain.CTYPES_FLOOR, 10, 10.0),
        _outcome(chain.FMIONNX, 10, 15.0),
        _outcome(chain.FMPY_LOOP, 10, 30.0),
        chain.Outcome(chain.SIMULATE_FMU, 10, skipped="one FMU only"),
        _outcome(chain.LIBCOSIM, 10, 12.0),
    ]
    rows = {r["contender"]: r for r in report.chain_rows(outcomes)}
    assert rows[chain.FMIONNX]["vs_floor"] == pytest.approx(1.5)
    assert rows[chain.FMPY_LOOP]["vs_fmionnx"] == pytest.approx(2.0)
    assert rows[chain.FMIONNX]["us_per_fmu_step"] == pytest.approx(1.5)
    assert rows[chain.SIMULATE_FMU]["median_us_per_step"] is None
    targets = {t["target"]: t["met"] for t in report.chain_targets(outcomes)}
    assert targets == {
        "N=10: fmionnx / fmpy loop": True,
        "N=10: fmionnx / ctypes floor": True,
        "N=10: fmionnx / libcosimpy": False,
    }


def test_quick_run_prints_the_tables_and_writes_results_json(tmp_path: Path) -> None:
    out = tmp_path / "bench" / "results.json"
    text = io.StringIO()
    run.main(["--quick", "--skip-scenario", "--out", str(out)], Console(file=text, width=200))
    document = json.loads(out.read_text(encoding="utf-8"))
    assert {"date", "machine", "chain", "scenario", "targets", "external"} <= set(document)
    assert document["machine"]["cores"] >= 1
    assert "fmpy" in document["machine"]["packages"]
    assert {r["n"] for r in document["chain"]["rows"]} == {1, 3}
    printed = text.getvalue()
    assert "Master overhead" in printed
    assert "Targets" in printed


def test_other_benchmark_scripts_are_found_by_name(tmp_path: Path) -> None:
    names = ("validate_large.py", "ros2_wire.py", "ros2_nodes.py", "isolation.py", "chain.py")
    for name in (*names, "native_reach.py"):
        (tmp_path / name).write_text("", encoding="utf-8")
    (tmp_path / "startup.py").write_text("", encoding="utf-8")
    assert [p.name for p in run.external_scripts(tmp_path)] == [
        "validate_large.py",
        "ros2_nodes.py",
        "ros2_wire.py",
        "isolation.py",
        "native_reach.py",
        "startup.py",
    ]


def test_isolation_benchmark_runs_both_modes_to_the_same_results_and_prints_the_ratio() -> None:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    text = io.StringIO()
    results = isolation.main(["--quick"], Console(file=text, width=200))
    chain_rows = {r["mode"]: r for r in results["chain"]}
    assert chain_rows[isolation.ISOLATED]["isolated"] == "g0, g1, g2, g3"
    assert all(r["correct"] and r["steps"] == 200 for r in chain_rows.values())
    assert chain_rows[isolation.ISOLATED_PYTHON]["isolated"] == "g0, g1, g2, g3"
    assert [chain_rows[m]["handover"] for m in (isolation.ISOLATED, isolation.ISOLATED_PYTHON)] == [
        "kernel",
        "Python",
    ]
    scenario_rows = {r["mode"]: r for r in results["scenario"]}
    assert set(scenario_rows) == {
        isolation.INPROCESS,
        isolation.ISOLATED,
        isolation.ISOLATED_PYTHON,
    }
    assert all(r["correct"] for r in scenario_rows.values())
    assert scenario_rows[isolation.ISOLATED]["vs_inprocess"] > 0
    assert [t["limit"] for t in results["targets"]] == ["<= 1.5"]
    assert results["leftover_children"] == []
    printed = text.getvalue()
    assert "Chain of 4 Gain FMUs" in printed
    assert "Reference scenario" in printed
    assert "Targets" in printed


@pytest.mark.parametrize(
    ("filename", "name", "category"),
    [
        ("~", "<built-in method mujoco._functions.mj_step2>", scenario.PHYSICS),
        ("~", "<built-in method mujoco._functions.mjr_render>", scenario.RENDERING),
        ("/x/onnxruntime/capi/session.py", "run", scenario.INFERENCE),
        ("/x/fmionnx/kinds/fmu/runner.py", "step", scenario.FMUS),
        ("/x/fmionnx/runtime/transfer.py", "scalar_copy", scenario.MASTER),
        ("~", "<built-in method math.isnan>", None),
    ],
)
def test_profiled_functions_fall_into_categories(
    filename: str, name: str, category: str | None
) -> None:
    assert scenario.categorize(filename, name) == category


def test_reference_scenario_measures_both_loops_and_every_category() -> None:
    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    real = scenario.real_time(0.2, 1)
    assert real.simulated == pytest.approx(0.2)
    assert len(real.fmionnx) == len(real.handwritten) == 1
    timers = scenario.timed_breakdown(0.2)
    # 100 physics steps, 20 steps of each FMU, 2 detector runs, 2 rendered frames
    assert timers.calls == {
        scenario.PHYSICS: 100,
        scenario.FMUS: 40,
        scenario.INFERENCE: 2,
        scenario.RENDERING: 2,
    }
    assert timers.seconds[scenario.MASTER] >= 0.0
    prof = scenario.profile(0.2)
    assert prof.seconds.get(scenario.PHYSICS, 0.0) > 0.0
    assert prof.seconds.get(scenario.FMUS, 0.0) > 0.0
    assert prof.top


@pytest.mark.slow  # a benchmark's quick run: `make soak`
def test_startup_benchmark_times_both_commands_and_every_run_mode_side_by_side() -> None:
    text = io.StringIO()
    results = startup.main(["--quick"], Console(file=text, width=200))
    assert [r["contender"] for r in results["help"]] == [startup.FMPY, startup.FMIONNX]
    runs = {r["contender"]: r for r in results["end_to_end"]}
    libcosim_here = chain.libcosim_problem() is None
    peers = [startup.LIBCOSIM_SCRIPT] if libcosim_here else []
    assert list(runs) == [
        startup.FMPY_SIMULATE, startup.RUN_DEFAULT, startup.RUN_DEFAULT_COLD, startup.RUN_FMUS,
        startup.RUN_GUARDIAN, startup.RUN_NONE, *peers, startup.IMPORT_FMU,
    ]  # fmt: skip
    # Every simulation's CSV agrees with FMPy's, the libcosim script's included.
    assert all(r["same_values"] for r in runs.values() if r["contender"] != startup.IMPORT_FMU)
    # A peer that is not measured is named, with why.
    missing = results["peers_missing"]
    assert any(line.startswith("OMSimulator") for line in missing)
    assert any(line.startswith("Ecos") for line in missing)
    assert libcosim_here or any(line.startswith(startup.LIBCOSIM_SCRIPT) for line in missing)
    assert runs[startup.FMPY_SIMULATE]["vs_fmpy"] == 1
    assert all(r["vs_fmpy"] > 0 for r in [*results["help"], *runs.values()])
    checks = {r["contender"]: r for r in results["validate"]}
    assert list(checks) == [startup.IMPORT_NUMPY, startup.VALIDATE, startup.VALIDATE_COLD]
    assert checks[startup.IMPORT_NUMPY]["vs_fmpy"] == 1
    (imports, reference) = results["reference"]
    assert imports["contender"] == startup.IMPORT_RUN
    assert reference["loop_s"] > 0  # read from run.json: what is outside is the rest
    assert reference["median_s"] > 0
    limits = [t["limit"] for t in results["targets"]]
    assert limits == ["<= 1", *["<= 0.4"] * 5, "<= 4", "<= 4", "<= 1.5", None]
    printed = text.getvalue()
    assert "One FMU end to end" in printed
    assert "Validate the reference system" in printed
    assert "time outside its loop" in printed
    assert "OMSimulator's CLI: not measured" in printed
    assert "Targets" in printed
