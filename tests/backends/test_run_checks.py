"""``fmionnx run`` with checks: the table, run.json, and exit 1 on a failed check, results kept."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.results.csvfile import read_csv

#: ``s.x`` is a ramp (x = t), recorded only because a check reads it; ``s.y`` is listed.
CHECKED = """\
fmionnx: 1
name: checked
run: {{stop: 2, step: 0.01}}
components:
  s: {{kind: signal, outputs: {{x: {{ramp: {{time: 0, slope: 1}}}}, y: {{constant: 2}}}}}}
record: [s.y]
checks:
  - name: ends at two
    expect: final(s.x) > 1.99
  - name: {name}
    expect: {expect}
"""


def _run(write_system, tmp_path, expect: str, *options: str, name: str = "too strict"):
    system = write_system(CHECKED.format(expect=expect, name=name))
    out = tmp_path / "out"
    runner = CliRunner()
    result = runner.invoke(app, ["run", str(system), "--out", str(out), *options])
    return result, out


def test_a_failed_check_exits_1_with_every_result_written(write_system, tmp_path) -> None:
    result, out = _run(write_system, tmp_path, "max(s.x) < 1")
    assert result.exit_code == 1, result.output
    table = read_csv(out / "results.csv")
    assert list(table) == ["time", "s.y", "s.x"]  # s.x: recorded for the check
    assert table["s.x"][-1] == 2.0
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert info["status"] == "completed"
    assert [(c["name"], c["value"], c["bound"], c["passed"]) for c in info["checks"]] == [
        ("ends at two", 2.0, 1.99, True),
        ("too strict", 2.0, 1.0, False),
    ]
    assert info["checks"][1]["expression"] == "max(s.x) < 1"
    assert (out / "run.json").name in info["files"]
    assert "FAIL" in result.output
    assert "1 of 2 checks failed" in result.output
    assert result.output.strip().splitlines()[-1] == f"Results: {out}"


def test_no_checks_skips_the_verdicts_of_a_shortened_run(write_system, tmp_path) -> None:
    result, out = _run(write_system, tmp_path, "max(s.x) < 1", "--no-checks")
    assert result.exit_code == 0, result.output
    assert "FAIL" not in result.output
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert info["checks"] == []


def test_checks_that_hold_exit_0_and_are_tabled(write_system, tmp_path) -> None:
    result, out = _run(write_system, tmp_path, "first_time(s.x >= 1.5) <= 1.5", name="half way")
    assert result.exit_code == 0, result.output
    assert "all 2 checks passed" in result.output
    assert "half way" in result.output
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    assert [c["passed"] for c in info["checks"]] == [True, True]
    assert info["checks"][1]["value"] == 1.5


def test_quiet_prints_only_the_failed_check(write_system, tmp_path) -> None:
    result, out = _run(write_system, tmp_path, "first_time(s.x > 7) < 1", "--quiet")
    assert result.exit_code == 1
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert lines == ["check failed: too strict: the condition never holds", f"Results: {out}"]


def test_a_broken_check_stops_run_before_it_starts(write_system, tmp_path) -> None:
    result, out = _run(write_system, tmp_path, "final(s.q) < 1")
    assert result.exit_code == 1
    assert "E091" in result.output
    assert "has no port `q`" in result.output
    assert "Traceback" not in result.output
    assert not (out / "results.csv").exists()


def test_both_backends_record_what_the_checks_read(write_system) -> None:
    from fmionnx import api
    from fmionnx.backends.ros2.recording import record_refs
    from fmionnx.core.types import PortRef
    from fmionnx.runtime.master import Master

    system = api.load(write_system(CHECKED.format(expect="max(s.x) < 1", name="n"))).compiled
    expected = (PortRef("s", "y"), PortRef("s", "x"))
    assert tuple(dict.fromkeys(Master(system).record_refs)) == expected
    assert tuple(dict.fromkeys(record_refs(system))) == expected  # the ROS 2 nodes: the same
