"""``run`` refuses runs that would never end, and its overrides are range-checked.

Every refusal here happens before the first step, so none of these tests simulates: a broken
check would start a run of 10^11 steps (or end in an OverflowError traceback) instead.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.api import OverrideError, load, parse_value
from fmionnx.cli.app import app
from fmionnx.core.errors import DiagnosticError
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: limits
run: {{stop: {stop}, step: 0.01}}
components:
  gain: {{kind: fmu, path: Gain.fmu}}
"""


@pytest.fixture
def system(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "300")
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(stop=1), encoding="utf-8")
    return path


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["run", "-q", *args], catch_exceptions=False)
    return result.exit_code, result.output


def test_run_refuses_more_than_ten_billion_steps(system: Path) -> None:
    system.write_text(SYSTEM.format(stop="1e9"), encoding="utf-8")  # 10**11 steps
    code, output = run(str(system), "--out", "out")
    assert code == 2
    assert "the run is 1e+11 base steps, more than --max-steps 1e+10" in output
    assert not (system.parent / "out" / "results.csv").exists()


def test_max_steps_lowers_the_limit_after_the_stop_time_override(system: Path) -> None:
    code, output = run(str(system), "--stop-time", "2", "--max-steps", "100", "--out", "out")
    assert code == 2
    assert "the run is 200 base steps, more than --max-steps 100" in output


def test_max_steps_must_be_positive(system: Path) -> None:
    code, output = run(str(system), "--max-steps", "0")
    assert code == 2
    assert "--max-steps must be at least 1" in output


def test_a_run_within_max_steps_runs(system: Path) -> None:
    code, output = run(str(system), "--max-steps", "100", "--out", "out")
    assert code == 0, output
    assert (system.parent / "out" / "results.csv").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--stop-time", "1e308"], "--stop-time 1e+308: the run from 0.0 to 1e+308 is more than 2**53"),
        (["--stop-time", "1e400"], "--stop-time inf must be a finite number"),
        (["-p", "gain.k=1e400"], "--param value `1e400` is beyond the range of a 64-bit float"),
        (["-p", "gain.k=[1e400]"], "--param value `1e400` is beyond the range"),
        (["-p", "gain.k=1" + "0" * 5000], "has more than 400 digits"),
        (["-p", "gain.k=1" + "0" * 350], "is beyond the range of float64"),
        (["-p", "gain.k=NaN"], "--param `gain.k`: nan is not a number (NaN); a parameter takes a number"),
        (["-p", "gain.k=[NaN]"], "--param `gain.k`: nan is not a number (NaN)"),
    ],
)  # fmt: skip
def test_out_of_range_overrides_are_one_line_errors(
    system: Path, args: list[str], message: str
) -> None:
    code, output = run(str(system), *args, "--out", "out")
    assert code == 2
    assert "Traceback" not in output
    assert message in " ".join(output.split())
    assert not (system.parent / "out" / "results.csv").exists()


def test_overrides_through_the_api(system: Path) -> None:
    loaded = load(system)
    with pytest.raises(OverrideError, match="more than 2\\*\\*53 base steps"):
        loaded.with_overrides(stop_time=1e300)
    with pytest.raises(OverrideError, match="beyond the range of float64"):
        loaded.with_overrides(params={"gain.k": 10**400})
    with pytest.raises(OverrideError, match="beyond the range of a 64-bit float"):
        parse_value("-1e999")
    assert loaded.with_overrides(params={"gain.k": 1e308}).compiled.run.steps == 100


@pytest.mark.parametrize("target", ["Gain.fmu", "system.yaml"])
@pytest.mark.parametrize(
    ("flags", "said"),
    [
        (["--step", "5e-324"], "--step 5e-324 is subnormal"),
        (["--step", "-1"], "--step -1.0 is not a positive finite number of seconds"),
        (["--step", "inf"], "--step inf is not a positive finite number of seconds"),
        (["--step", "nan"], "--step nan is not a positive finite number of seconds"),
        (["--start-time", "nan"], "--start-time nan must be a finite number of seconds"),
        (["--start-time", "2", "--stop-time", "1"], "--stop-time 1.0 must be greater than"),
    ],
)
def test_times_that_cannot_be_are_usage_errors_like_stop_time(
    system: Path, target: str, flags: list[str], said: str
) -> None:
    """``--step nan`` was E040 at the system file (exit 1), ``--stop-time nan`` exit 2."""
    code, output = run(target, *flags, "--out", "out")
    assert code == 2, output
    assert "Traceback" not in output
    assert said in output
    assert not Path("out").exists()


@pytest.mark.parametrize("target", ["Gain.fmu", "system.yaml"])
def test_a_start_past_the_files_stop_runs_with_a_stop_time(system: Path, target: str) -> None:
    """``--start-time 5 --stop-time 5.5`` was refused (E040 at `run.stop`): the start was
    compiled in, the stop applied only after compiling."""
    code, output = run(target, "--start-time", "5", "--stop-time", "5.5", "--out", "out")
    assert code == 0, output
    times = [row.split(",")[0] for row in Path("out/results.csv").read_text().splitlines()[1:]]
    assert (times[0], times[-1]) == ("5", "5.5")


def test_a_start_past_the_files_stop_alone_names_the_option(system: Path) -> None:
    code, output = run("system.yaml", "--start-time", "5", "--out", "out")
    assert code == 1
    text = " ".join(output.split())
    assert "--start-time 5.0 is not before the system's stop time 1.0 (`run.stop`)" in text
    assert "give --stop-time too" in text


def test_load_takes_a_stop_time_alone_or_with_a_start(system: Path) -> None:
    """`fmionnx.load(path, stop=...)` was accepted and ignored without `start` (a review)."""
    assert load(system, stop=0.5).compiled.run.stop == 0.5
    both = load(system, start=5.0, stop=5.5).compiled.run
    assert (both.start, both.stop) == (5.0, 5.5)
    with pytest.raises(DiagnosticError, match=r"--stop-time 0\.0 is not after"):
        load(system, stop=0.0)
