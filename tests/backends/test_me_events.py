"""Model exchange with events, FMI 2 and FMI 3, against FMPy on the same FMUs (issue #33).

The fixtures (``tests/fixtures/fmus/{Feedthrough,BouncingBall,Stair}{2,3}``, one C source)
behave like the Modelica Reference FMUs of the same names: discrete inputs that only Event
Mode may set, state events, time events with ``nextEventTime``, and a model that asks to
terminate at an event.

FMPy integrates with the same CVode binding, the same relative tolerance and the same maximum
step, and fmionnx integrates the same intervals (a lone FMU's communication points are FMPy's
output points), so the two agree to far below the solver tolerance. The tolerance used,
``1e-6`` absolute on metres and metres per second, is ten times tighter than CVode's own
relative tolerance (1e-5) times the values' scale (about 1): any difference in the event
handling (an event missed or placed at another time, a bounce applied twice) moves the
trajectory by centimetres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.results.csvfile import read_csv
from fmionnx.runtime.result import RunStatus

VERSIONS = ("2", "3")


@pytest.mark.parametrize("version", VERSIONS)
def test_feedthrough_runs_in_model_exchange_from_the_command_line(
    fixture_fmu, tmp_path: Path, version: str
) -> None:
    # the report: `fmionnx run Feedthrough.fmu --interface me` stopped at t = 0 with
    # "Variable Float64_discrete_input can only be set ... in initialization mode or event mode"
    fmu = fixture_fmu(f"Feedthrough{version}")
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(fmu), "--interface", "me", "--out", str(out), "-q"]
    )
    assert result.exit_code == 0, result.output
    table = read_csv(out / "results.csv")
    assert table["time"][-1] == pytest.approx(2.0)


@pytest.mark.parametrize("version", VERSIONS)
def test_discrete_inputs_are_set_in_event_mode_and_reach_the_outputs(
    fixture_fmu, write_system, version: str
) -> None:
    # the FMU refuses a discrete input in Continuous-Time Mode (as the Reference FMU does), so
    # a run that completes set it in Event Mode; each row shows the outputs for the inputs of
    # the same communication point (the signal is a direct feedthrough, stepped first)
    fmu = fixture_fmu(f"Feedthrough{version}")
    path = write_system(
        f"""
fmionnx: 1
name: feed
run: {{start: 0, stop: 1, step: 0.1}}
components:
  src:
    kind: signal
    outputs:
      d: {{step: {{time: 0.5, final: 2.0}}}}
      c: {{ramp: {{slope: 1.0}}}}
  ft: {{kind: fmu, path: {fmu}, interface: me}}
connections:
  - src.d -> ft.Float64_discrete_input
  - src.c -> ft.Float64_continuous_input
record: [ft.Float64_discrete_output, ft.Float64_continuous_output]
"""
    )
    result = fmionnx.load(path).run()
    assert result.status is RunStatus.COMPLETED, result.ended_by
    time = np.asarray(result.time)
    expected_discrete = np.where(time >= 0.5 - 1e-12, 2.0, 0.0)
    np.testing.assert_allclose(result["ft.Float64_discrete_output"], expected_discrete)
    expected_continuous = time
    np.testing.assert_allclose(
        result["ft.Float64_continuous_output"], expected_continuous, atol=1e-12
    )


def _fmpy(fmu: Path, names: list[str], stop: float, step: float) -> np.ndarray:
    return simulate_fmu(
        str(fmu),
        fmi_type="ModelExchange",
        stop_time=stop,
        output_interval=step,
        output=names,
        record_events=False,
    )


@pytest.mark.parametrize("version", VERSIONS)
def test_bouncing_ball_state_events_match_fmpy(fixture_fmu, version: str) -> None:
    fmu = fixture_fmu(f"BouncingBall{version}")
    ours = fmionnx.load(fmu, interface="me", step=0.01).run(stop_time=3.0)
    assert ours.status is RunStatus.COMPLETED, ours.ended_by
    theirs = _fmpy(fmu, ["h", "v"], 3.0, 0.01)
    np.testing.assert_allclose(ours.time, theirs["time"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ours["h"], theirs["h"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours["v"], theirs["v"], rtol=0, atol=1e-6)
    # it bounced (v changed sign upwards) and came to rest on the ground by t = 3 s
    assert np.any(np.asarray(ours["v"]) > 1.0)
    assert ours["h"][-1] == 0.0
    assert ours["v"][-1] == 0.0


@pytest.mark.parametrize("version", VERSIONS)
def test_stair_time_events_match_fmpy_and_the_terminal_event_ends_the_run(
    fixture_fmu, version: str
) -> None:
    fmu = fixture_fmu(f"Stair{version}")
    ours = fmionnx.load(fmu, interface="me", step=0.2).run(stop_time=10.0)
    assert ours.status is RunStatus.COMPLETED, ours.ended_by
    theirs = _fmpy(fmu, ["counter"], 10.0, 0.2)
    time = np.asarray(ours.time)
    # every row before the terminal event equals FMPy's (a step at each whole second)
    shared = len(theirs)
    np.testing.assert_allclose(time[:shared], theirs["time"][:shared], atol=1e-12)
    np.testing.assert_array_equal(ours["counter"][:shared], theirs["counter"][:shared])
    np.testing.assert_array_equal(ours["counter"][:shared], np.floor(time[:shared] + 1e-9) + 1)
    # the terminal event: at t = 9 the counter reaches 10 and the model asks to terminate
    # (fmi2NewDiscreteStates / fmi3UpdateDiscreteStates terminateSimulation = true); the run
    # ends there with the values the event iteration produced, its last row t = 9, counter
    # 10, as FMPy's co-simulation reports it (FMPy's model exchange stops without a row at
    # t = 9: its last row is 8.8)
    assert ours.ended_by is not None
    assert ours.ended_by.time == pytest.approx(9.0)
    assert time[-1] == pytest.approx(9.0)
    assert ours["counter"][-1] == 10
    assert len(time) == shared + 1
    assert theirs["time"][-1] == pytest.approx(8.8)


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("model", ["BouncingBall", "Stair", "Feedthrough"])
def test_co_simulation_of_the_event_fixtures_matches_fmpy(
    fixture_fmu, version: str, model: str
) -> None:
    fmu = fixture_fmu(f"{model}{version}")
    ours = fmionnx.load(fmu, interface="cs").run()
    theirs = simulate_fmu(str(fmu), fmi_type="CoSimulation")
    names = [n for n in theirs.dtype.names if n != "time"]
    rows = min(len(ours.time), len(theirs))
    np.testing.assert_allclose(ours.time[:rows], theirs["time"][:rows], atol=1e-12)
    for name in names:
        np.testing.assert_allclose(
            np.asarray(ours[name][:rows], dtype=float),
            np.asarray(theirs[name][:rows], dtype=float),
            rtol=0,
            atol=1e-12,
            err_msg=name,
        )


@pytest.mark.parametrize("version", VERSIONS)
def test_feedthrough_alone_in_model_exchange_matches_fmpy(fixture_fmu, version: str) -> None:
    # start values of every input type, discrete ones included, set before initialization
    fmu = fixture_fmu(f"Feedthrough{version}")
    starts = {
        "Float64_continuous_input": 1.5,
        "Float64_discrete_input": 3.0,
        "Int32_input": 7,
        "Boolean_input": True,
    }
    ours = fmionnx.load(fmu, interface="me", step=0.5).run(stop_time=2.0, params=starts)
    assert ours.status is RunStatus.COMPLETED, ours.ended_by
    outputs = [name.replace("input", "output") for name in starts]
    theirs = simulate_fmu(
        str(fmu),
        fmi_type="ModelExchange",
        stop_time=2.0,
        output_interval=0.5,
        start_values=starts,
        output=outputs,
        record_events=False,
    )
    np.testing.assert_allclose(ours.time, theirs["time"], atol=1e-12)
    for name in outputs:
        np.testing.assert_array_equal(
            np.asarray(ours[name], dtype=float), np.asarray(theirs[name], dtype=float), name
        )
    assert ours["Int32_output"][-1] == 7
