"""The test FMUs other tests build on: they pass fmpy's validation and simulate as specified."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

FMUS = Path(__file__).resolve().parent.parent / "fixtures" / "fmus"
FMI2_FIXTURES = ("Gain", "Integrator", "Faulty", "Probe")

BuildFmu = Callable[[str], Path]


def _inputs(**columns: tuple[float, ...] | float) -> np.ndarray:
    """A constant input signal over [0, 10] for fmpy (one column per variable)."""
    names = list(columns)
    dtype = [("time", float)] + [
        (name, float, (len(v),)) if isinstance(v, tuple) else (name, float)
        for name, v in columns.items()
    ]
    rows = [(t, *(columns[n] for n in names)) for t in (0.0, 10.0)]
    return np.array(rows, dtype=dtype)


def test_fmi2_fixtures_share_one_glue_source() -> None:
    # each source FMU stays self-contained for build tools (a link, copied as a file by
    # build_fmu), while the glue itself exists once, in tests/fixtures/fmus/common
    for file in ("fmi2_glue.c", "fmi2_glue.h"):
        for name in FMI2_FIXTURES:
            path = FMUS / name / "sources" / file
            assert path.is_symlink(), f"{path} should link to common/{file}"
            assert path.resolve() == (FMUS / "common" / file).resolve()


EVENT_FIXTURES = tuple(
    f"{model}{version}" for model in ("Feedthrough", "BouncingBall", "Stair") for version in "23"
)


def test_event_fixtures_share_one_source() -> None:
    # the FMI 2 and FMI 3 models with events (issue #33) are built from one C file
    for name in EVENT_FIXTURES:
        path = FMUS / name / "sources" / "events.c"
        assert path.is_symlink(), f"{path} should link to common/events.c"
        assert path.resolve() == (FMUS / "common" / "events.c").resolve()


@pytest.mark.parametrize(
    "name", ["Gain", "Integrator", "Faulty", "Probe", "Vector3", *EVENT_FIXTURES]
)
def test_fixture_fmu_passes_fmpy_validation(fixture_fmu: BuildFmu, name: str) -> None:
    assert validate_fmu(str(fixture_fmu(name))) == []


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_gain_multiplies_scalar_and_array_inputs(fixture_fmu: BuildFmu, fmi_type: str) -> None:
    result = simulate_fmu(
        str(fixture_fmu("Gain")),
        fmi_type=fmi_type,
        stop_time=0.1,
        start_values={"k": 3.0},
        input=_inputs(u=1.5, **{"v[1]": 1.0, "v[2]": 2.0, "v[3]": -4.0}),
        output=["y", "w[1]", "w[2]", "w[3]"],
    )
    last = result[-1]
    assert (last["y"], last["w[1]"], last["w[2]"], last["w[3]"]) == (4.5, 3.0, 6.0, -12.0)


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_integrator_integrates_from_x0(fixture_fmu: BuildFmu, fmi_type: str) -> None:
    result = simulate_fmu(
        str(fixture_fmu("Integrator")),
        fmi_type=fmi_type,
        stop_time=1.0,
        output_interval=0.05,
        start_values={"x0": 1.0},
        input=_inputs(u=2.0),
        output=["x"],
    )
    assert result[0]["x"] == 1.0
    assert result[-1]["x"] == pytest.approx(3.0, rel=1e-9)


def test_vector3_gains_array_and_counts_steps(fixture_fmu: BuildFmu) -> None:
    result = simulate_fmu(
        str(fixture_fmu("Vector3")),
        stop_time=1.0,
        output_interval=0.1,
        start_values={"k": 3.0},
        input=_inputs(u=(1.0, 2.0, 3.0)),
    )
    assert list(result[-1]["y"]) == [3.0, 6.0, 9.0]
    assert result[-1]["count"] == 10


def test_faulty_mode_0_fails_do_step_at_fail_time(fixture_fmu: BuildFmu) -> None:
    with pytest.raises(Exception, match="fmi2DoStep failed with status 3"):
        simulate_fmu(
            str(fixture_fmu("Faulty")),
            stop_time=1.0,
            output_interval=0.1,
            start_values={"mode": 0},
            logger=lambda *_: None,
        )


def test_faulty_mode_1_outputs_nan_from_fail_time(fixture_fmu: BuildFmu) -> None:
    result = simulate_fmu(
        str(fixture_fmu("Faulty")),
        stop_time=1.0,
        output_interval=0.1,
        start_values={"mode": 1, "failAt": 0.3},
        input=_inputs(u=7.0),
    )
    before = [row["y"] for row in result if row["time"] < 0.3 - 1e-9]
    after = [row["y"] for row in result if row["time"] > 0.3 - 1e-9]
    assert before == [7.0] * len(before)
    assert after
    assert all(math.isnan(y) for y in after)


def test_faulty_mode_10_completes_the_step_then_fmpy_stops_on_fmi2_terminated(
    fixture_fmu: BuildFmu,
) -> None:
    # FMPy's own reading of fmi2Discard + fmi2Terminated: the end of the simulation at the
    # last successful time, which is the end of the step from failAt (0.5). A plain discard
    # (mode 2) reports fmi2Terminated false: FMPy would retry it for ever, fmionnx faults.
    result = simulate_fmu(
        str(fixture_fmu("Faulty")),
        stop_time=1.0,
        output_interval=0.1,
        start_values={"mode": 10},
    )
    assert result[-1]["time"] == pytest.approx(0.6)
