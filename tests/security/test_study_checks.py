"""A study's names are checked before its first case; a flood of one mistake prints briefly.

A study's table is written after its last case: a metric it cannot take as a column (named
``case`` or ``status``, ``check: x``, 400 characters, the name of a target) lost every
case's row, or a plot's file could not be written, after hours of running. All of it is E109
when the study is compiled (``validate`` and ``sweep`` alike). 20 000 metrics drew 20 000
plots; the plots now draw :data:`~fmionnx.compile.studyir.PLOTTED_METRICS` (W100). And a
system file of tens of thousands of duplicate connections printed five lines for each: the
text report shows the first of each code and counts the rest.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from fmionnx.api import check_study
from fmionnx.compile.study import compile_study
from fmionnx.compile.studyir import PLOTTED_METRICS
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.reporters.common import SHOWN_PER_CODE
from fmionnx.results.casetable import CaseTable
from fmionnx.results.study_plots import write_study_plots
from fmionnx.spec.study import load_study

SYSTEM = """
fmionnx: 1
name: gain
run: {{stop: 0.1, step: 0.01}}
inputs:
  status: {{to: [gain.k]}}
components:
  gain: {{kind: fmu, path: {gain}}}
"""


@pytest.fixture
def folder(tmp_path: Path, fixture_fmu) -> Path:
    (tmp_path / "system.yaml").write_text(SYSTEM.format(gain=fixture_fmu("Gain")), "utf-8")
    return tmp_path


def _study(folder: Path, metrics: dict[str, str], target: str = "gain.u") -> Path:
    lines = ["fmionnx: 1", "system: system.yaml", "parameters:", f"  {target}: [1, 2]", "metrics:"]
    lines += [f"  {json.dumps(name)}: {expression}" for name, expression in metrics.items()]
    path = folder / "study.yaml"
    path.write_text("\n".join(lines) + "\n", "utf-8")
    return path


@pytest.mark.parametrize(
    ("name", "problem"),
    [
        ("case", "one of the study table's own columns"),
        ("status", "one of the study table's own columns"),
        ("wall_time", "one of the study table's own columns"),
        ("check: x", "would be taken for a check's column"),
        ("m" * 400, "the name has 400 characters, more than 64"),
        ("gain.u", "also a target of the study"),
        ("final y", "not a plain name"),
        ("../y", "not a plain name"),
    ],
    ids=["case", "status", "wall_time", "check", "400-characters", "target", "space", "path"],
)
def test_a_metric_the_table_cannot_take_is_e109_before_any_case(
    folder: Path, name: str, problem: str
) -> None:
    study = _study(folder, {name: "final(gain.y)"})
    result = check_study(study)
    errors = [d for d in result.diagnostics if d.code == "E109"]
    assert len(errors) == 1, result.diagnostics
    assert problem in errors[0].message
    assert errors[0].span is not None
    assert errors[0].span.line == 6


def test_a_target_named_like_a_column_of_the_table_is_e109(folder: Path) -> None:
    study = _study(folder, {"y": "final(gain.y)"}, target="status")
    (error,) = [d for d in check_study(study).diagnostics if d.code == "E109"]
    assert "the target `status` has the name of a column" in error.message


def test_sweep_refuses_the_study_before_it_runs_a_case(folder: Path) -> None:
    study = _study(folder, {"status": "final(gain.y)"})
    out = folder / "out"
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", "sweep", str(study), "--out", str(out)],
        capture_output=True, text=True, timeout=120, check=False, cwd=folder,
    )  # fmt: skip
    assert done.returncode == 1, done.stdout + done.stderr
    assert "E109" in done.stdout + done.stderr
    assert not (out / "records").exists()
    assert "Traceback" not in done.stderr


def test_twenty_thousand_metrics_draw_a_bounded_number_of_plots(folder: Path) -> None:
    metrics = {f"m{i}": "final(gain.y)" for i in range(20_000)}
    study = _study(folder, metrics)
    bag = DiagnosticBag()
    plan = compile_study(load_study(study, bag), bag)
    assert plan is not None
    (warning,) = [d for d in bag if d.code == "W100"]
    assert f"draw {PLOTTED_METRICS} of them" in warning.message
    assert len(plan.metrics) == 20_000
    columns = ("case", "gain.u", "status", *metrics)
    rows = (("case-0000", 1.0, "ok", *(0.0,) * len(metrics)),
            ("case-0001", 2.0, "ok", *(1.0,) * len(metrics)))  # fmt: skip
    table = CaseTable(columns, rows)
    out = folder / "plots"
    out.mkdir()
    written = write_study_plots(table, plan, out)
    assert len(written) == PLOTTED_METRICS


def test_the_objective_is_among_the_plotted_metrics(folder: Path) -> None:
    metrics = {f"m{i}": "final(gain.y)" for i in range(PLOTTED_METRICS + 5)}
    study = _study(folder, metrics)
    study.write_text(
        study.read_text("utf-8") + f"objective: {{minimize: m{PLOTTED_METRICS + 3}}}\n"
    )
    bag = DiagnosticBag()
    plan = compile_study(load_study(study, bag), bag)
    assert plan is not None
    assert plan.plotted_metrics[0].name == f"m{PLOTTED_METRICS + 3}"
    assert len(plan.plotted_metrics) == PLOTTED_METRICS


def test_thousands_of_duplicate_connections_print_a_bounded_report(
    tmp_path: Path, fixture_fmu
) -> None:
    count = 3_000
    system = tmp_path / "dup.yaml"
    system.write_text(
        f"fmionnx: 1\nname: dup\nrun: {{stop: 0.1, step: 0.01}}\ncomponents:\n"
        f"  s: {{kind: signal, outputs: {{y: {{constant: 1}}}}}}\n"
        f"  g: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{v: [0, 0, 0]}}}}\n"
        "connections:\n" + "  - s.y -> g.u\n" * count,
        "utf-8",
    )
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", "validate", str(system)],
        capture_output=True, text=True, timeout=600, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 1
    lines = done.stdout.splitlines()
    assert len(lines) < 6 * SHOWN_PER_CODE
    assert f"... and {count - 1 - SHOWN_PER_CODE} more diagnostics [E034 multiple-drivers]" in (
        done.stdout
    )
    assert lines[-1] == f"{count - 1} errors in 1 file"
    json_report = subprocess.run(
        [sys.executable, "-m", "fmionnx", "validate", str(system), "--format", "json"],
        capture_output=True, text=True, timeout=600, check=False, cwd=tmp_path,
    )  # fmt: skip
    listed = json.loads(json_report.stdout)["files"][0]["diagnostics"]
    assert len(listed) == count - 1  # the machine-readable report keeps every one
