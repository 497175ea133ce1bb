"""Fuzzing study files: mutated valid studies end in diagnostics or a plan whose every case
applies to the system, never a traceback or a hang.

``fmionnx sweep`` and ``fmionnx validate study.yaml`` compile a study with
:func:`fmionnx.api.check_study`; every case of the plan is then applied to the compiled system
on a worker (:func:`fmionnx.compile.studyir.apply_case`), where an exception would end the case
as ``failed`` with a Python message instead of the study refusing it up front. The seeds vary a
small FMU system in every way the study file offers: grid axes, ranges, samples, Latin
hypercubes, a signal's settings, run settings, array parameters, metrics, an objective.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fmionnx import api
from fmionnx.compile.studyir import apply_case
from fmionnx.pipeline.sweep import plan_study
from fmionnx.results.casetable import CaseTable
from fmionnx.results.study import StudyFolder
from fmionnx.results.study_plots import write_study_plots
from tests.conftest import build_fixture_fmu
from tests.fuzz.harness import check_diagnostics, fuzz_settings, guarded, record, write_input
from tests.fuzz.mutations import YAML_TOKENS, dump_yaml, load_yaml, mutated_bytes, mutated_yaml

SYSTEM = """\
fmionnx: 1
name: chain
run: {stop: 1, step: 0.01}
components:
  src: {kind: signal, outputs: {y: {sine: {amplitude: 1, frequency: 0.5}}}}
  integ: {kind: fmu, path: Integrator.fmu}
  gain: {kind: fmu, path: Gain.fmu, parameters: {v: [0, 0, 0]}}
connections:
  - src.y -> integ.u
  - integ.x -> gain.u
checks:
  - name: small
    expect: final(gain.y) < 3
"""
SEEDS = {
    "grid": """\
fmionnx: 1
system: system.yaml
description: a grid of two axes
parameters:
  gain.k: [0.5, 1, 2]
  integ.x0: {range: {start: 0, stop: 1, num: 3}}
metrics:
  y_end: final(gain.y)
  peak: max(gain.y)
objective: {minimize: peak}
isolate: [none]
timeout: 30
""",
    "sampled": """\
fmionnx: 1
system: system.yaml
parameters:
  gain.k: {random: {low: 0.1, high: 2}}
  integ.x0: {latin_hypercube: {low: -1, high: 1}}
  src.amplitude: {values: [0.5, 1.5]}
  run.stop: [0.5, 1]
sampling: {samples: 4, seed: 3}
metrics:
  low: min(integ.x)
  when: first_time(gain.y > 0.5)
step_timeout: 5
""",
    "arrays": """\
fmionnx: 1
system: system.yaml
parameters:
  gain.v: [[0, 0, 1], [1, 0, 0]]
  src.frequency: {list: [0.25, 1]}
  run.output_interval: [0.02, 0.05]
metrics:
  mean_y: mean(gain.y)
  spread: max(gain.y) - min(gain.y)
objective: {maximize: spread}
""",
}
DOCUMENTS = {name: load_yaml(text) for name, text in SEEDS.items()}
#: Cases of a plan applied to the system per example (a plan may hold up to a million).
APPLIED = 8


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The system the studies vary, with its two FMUs beside it."""
    here = tmp_path_factory.mktemp("fuzz-study")
    for name in ("Integrator", "Gain"):
        shutil.copy(build_fixture_fmu(name), here / f"{name}.fmu")
    (here / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    return here


def write(folder: Path, data: bytes | str) -> Path:
    """The mutated study file, beside the system it varies."""
    return write_input(folder / "study.yaml", data)


def check_study(path: Path, data: bytes | str) -> None:
    """Compile the study; when it compiles, apply its first cases to the system."""
    result = guarded("check_study", data, lambda: api.check_study(path))
    check_diagnostics(result, data)
    if not result.ok:
        return
    plan, _ = guarded("plan_study", data, lambda: plan_study(path))
    for case in plan.cases[:APPLIED]:
        guarded(f"apply_case({case.id})", data, lambda c=case: apply_case(plan.system, c))  # type: ignore[misc]
    record(f"cases {min(len(plan.cases), 10)}{'+' if len(plan.cases) > 10 else ''}")


def test_every_seed_compiles_with_cases(folder: Path) -> None:
    """The fuzzers start from valid studies whose cases apply (see the YAML fuzzer's note)."""
    for name, text in SEEDS.items():
        path = write(folder, text)
        result = api.check_study(path)
        assert result.ok, (name, [d.message for d in result.diagnostics])
        plan, _ = plan_study(path)
        assert len(plan.cases) > 1, name
        for case in plan.cases:
            apply_case(plan.system, case)


@given(st.sampled_from(sorted(SEEDS)), st.data())
@fuzz_settings(150)
def test_byte_mutated_study_files_end_in_diagnostics(
    folder: Path, seed: str, data: st.DataObject
) -> None:
    mutated = data.draw(mutated_bytes(SEEDS[seed].encode(), YAML_TOKENS), label="study file")
    check_study(write(folder, mutated), mutated)


@given(st.sampled_from(sorted(SEEDS)), st.data())
@fuzz_settings(150)
def test_structure_mutated_study_files_end_in_diagnostics(
    folder: Path, seed: str, data: st.DataObject
) -> None:
    """Values of any type, huge and non-finite numbers, deep nesting, tags, aliases, dropped,
    misspelt and duplicated keys, values moved elsewhere."""
    mutated = data.draw(mutated_yaml(DOCUMENTS[seed]), label="study file")
    check_study(write(folder, mutated), mutated)


#: Names a metric may be given that the study's table or its plot files may choke on.
METRIC_NAMES = (
    "case", "status", "message", "wall_time", "worker", "check: small", "check: x", "gain.k",
    "integ.x0", "run.stop", "y_end", "Y_END", "y end", "y/end", "../y", "m" * 65, "m" * 400,
    "é", "\u202e", "1st", "_", "a.b", "a-b", "a:b", "",
)  # fmt: skip


@given(
    st.sampled_from(sorted(SEEDS)),
    st.lists(
        st.one_of(st.sampled_from(METRIC_NAMES), st.text(max_size=70)), min_size=1, max_size=3
    ),
)
@fuzz_settings(60)
def test_metric_names_end_in_diagnostics_or_a_table_that_can_be_written(
    folder: Path, seed: str, names: list[str]
) -> None:
    """A study whose metrics get any names either is refused when it is compiled, or its
    table (parquet and CSV, one column per metric) and its plots (a file per metric) can be
    written: what was lost after every case had run (issue #38)."""
    document = load_yaml(SEEDS[seed])
    document["metrics"] = dict.fromkeys(names, "final(gain.y)")
    document.pop("objective", None)
    text = dump_yaml(document)
    path = write(folder, text)
    result = guarded("check_study", text, lambda: api.check_study(path))
    check_diagnostics(result, text)
    if not result.ok:
        return
    plan, _ = guarded("plan_study", text, lambda: plan_study(path))
    out = folder / "table"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()

    def write_results() -> None:
        results = StudyFolder(out, plan)
        empty = results.table()
        rows = [
            [case.id, *(_plain_cell(s.value) for s in case.settings)]
            + [float(i) for i in range(len(plan.metrics))]
            + [True] * len(plan.check_names)
            + ["ok", "", 0.0, ""]
            for case in plan.cases[:2]
        ]
        table = CaseTable(empty.columns, tuple(tuple(row) for row in rows))
        results.write_table(table)
        write_study_plots(table, plan, out)

    guarded("write the table and plots", text, write_results)
    record("table written")


def _plain_cell(value: object) -> object:
    return list(value) if isinstance(value, tuple) else value
