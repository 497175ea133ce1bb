"""SignTrackingLogic FMU driven through scripted inputs: every state and every transition."""

from __future__ import annotations

import math
import shutil
from collections.abc import Iterator
from dataclasses import dataclass

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from tests.conftest import built_model

SEARCH, APPROACH, TURN_LEFT, TURN_RIGHT, STOP = range(5)
RED, GREEN, BLUE = range(3)
H = 0.01
CENTRE = 319.5  # centre column of a 640-pixel image


@dataclass(frozen=True)
class Out:
    state: int
    v: float
    w: float
    stop: bool


class Tracker:
    """The FMU in co-simulation; ``step`` sets all inputs, advances one period, reads outputs."""

    def __init__(self, **parameters: float | bool) -> None:
        path = built_model("SignTrackingLogic.fmu")
        self.description = read_model_description(str(path))
        self.unzipped = extract(str(path))
        self.vars = {v.name: v for v in self.description.modelVariables}
        self.slave = FMU2Slave(
            guid=self.description.guid,
            unzipDirectory=self.unzipped,
            modelIdentifier="SignTrackingLogic",
        )
        self.slave.instantiate()
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        for name, value in parameters.items():
            self.set(name, value)
        self.slave.exitInitializationMode()
        self.time = 0.0

    def set(self, name: str, value: float | bool) -> None:
        var = self.vars[name]
        setter = {
            "Real": self.slave.setReal,
            "Integer": self.slave.setInteger,
            "Boolean": self.slave.setBoolean,
        }[var.type]
        setter([var.valueReference], [value])

    def get(self, name: str) -> float:
        var = self.vars[name]
        getter = {
            "Real": self.slave.getReal,
            "Integer": self.slave.getInteger,
            "Boolean": self.slave.getBoolean,
        }[var.type]
        return getter([var.valueReference])[0]

    def step(
        self,
        sizes: tuple[float, float, float] = (0.0, 0.0, 0.0),
        xs: tuple[float, float, float] = (-1.0, -1.0, -1.0),
        pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> Out:
        for k in range(3):
            self.set(f"blobSize[{k + 1}]", sizes[k])
            self.set(f"blobX[{k + 1}]", xs[k])
        for name, value in zip(("posX", "posY", "theta"), pose, strict=True):
            self.set(name, value)
        self.slave.doStep(self.time, H)
        self.time += H
        return Out(
            int(self.get("state")), self.get("v"), self.get("w"), bool(self.get("stopRobot"))
        )

    def close(self) -> None:
        self.slave.terminate()
        self.slave.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)


@pytest.fixture
def tracker() -> Iterator[Tracker]:
    fmu = Tracker()
    yield fmu
    fmu.close()


def blob(colour: int, size: float, x: float = CENTRE) -> dict[str, tuple[float, float, float]]:
    sizes = [0.0, 0.0, 0.0]
    xs = [-1.0, -1.0, -1.0]
    sizes[colour], xs[colour] = size, x
    return {"sizes": (sizes[0], sizes[1], sizes[2]), "xs": (xs[0], xs[1], xs[2])}


def test_search_drives_at_cruise_speed_and_holds_the_initial_heading(tracker):
    out = tracker.step()
    assert out == Out(SEARCH, 0.5, 0.0, False)
    out = tracker.step(pose=(0.1, 0.0, 0.1))  # drifted left: steer back right
    assert out.state == SEARCH
    assert out.w == pytest.approx(-2.0 * 0.1)


def test_search_to_approach_steers_towards_the_sign_and_back_to_search_when_lost(tracker):
    out = tracker.step(**blob(BLUE, 100.0, CENTRE))
    assert out == Out(APPROACH, 0.4, 0.0, False)
    out = tracker.step(**blob(BLUE, 100.0, CENTRE + 160.0))  # sign right of centre
    assert out.state == APPROACH
    assert out.w == pytest.approx(-0.6 * 0.5)
    out = tracker.step(**blob(BLUE, 100.0, CENTRE - 320.0))
    assert out.w == pytest.approx(0.6)
    out = tracker.step(**blob(BLUE, 40.0))  # below detectSize: lost
    assert out == Out(SEARCH, 0.5, 0.0, False)


def test_approach_follows_the_largest_sign(tracker):
    sizes, xs = (150.0, 0.0, 100.0), (CENTRE + 320.0, -1.0, CENTRE - 320.0)
    out = tracker.step(sizes=sizes, xs=xs)
    assert out.state == APPROACH
    assert out.w == pytest.approx(-0.6)  # towards the red one, right of centre


def test_blue_sign_turns_left_90_degrees_closed_on_theta(tracker):
    tracker.step(**blob(BLUE, 100.0))
    out = tracker.step(**blob(BLUE, 320.0))
    assert out == Out(TURN_LEFT, 0.0, 0.8, False)
    out = tracker.step(pose=(3.0, 0.0, 1.5))  # the sign is out of view while turning
    assert out.state == TURN_LEFT
    assert out.w == pytest.approx(3.0 * (math.pi / 2 - 1.5))
    out = tracker.step(pose=(3.0, 0.0, math.pi / 2 - 0.005))
    assert out.state == SEARCH
    assert out.v == 0.5
    assert tracker.get("headingRef") == pytest.approx(math.pi / 2, abs=1e-15)


def test_green_sign_turns_right_90_degrees(tracker):
    tracker.step(**blob(GREEN, 100.0))
    out = tracker.step(**blob(GREEN, 300.0))
    assert out == Out(TURN_RIGHT, 0.0, -0.8, False)
    assert tracker.get("turnTarget") == pytest.approx(-math.pi / 2)
    out = tracker.step(pose=(0.0, 0.0, -math.pi / 2 + 0.2))
    assert out.w == pytest.approx(-0.6)
    out = tracker.step(pose=(0.0, 0.0, -math.pi / 2 - 0.02))  # overshoot: turn back
    assert out.state == TURN_RIGHT
    assert out.w == pytest.approx(0.06)
    out = tracker.step(pose=(0.0, 0.0, -math.pi / 2 + 0.009))
    assert out.state == SEARCH


def test_turn_left_across_pi_wraps_the_heading_error(tracker):
    tracker.step(pose=(0.0, 0.0, 3.1))  # heading -x: headingRef snaps to pi
    tracker.step(pose=(0.0, 0.0, 3.1), **blob(BLUE, 100.0))
    out = tracker.step(pose=(0.0, 0.0, 3.1), **blob(BLUE, 400.0))
    assert out.state == TURN_LEFT
    assert tracker.get("turnTarget") == pytest.approx(-math.pi / 2)
    out = tracker.step(pose=(0.0, 0.0, -3.1))  # just across -pi: keep turning left
    assert out.w == pytest.approx(0.8)
    out = tracker.step(pose=(0.0, 0.0, -math.pi / 2 - 0.001))
    assert out.state == SEARCH


def test_turn_right_across_pi_wraps_the_heading_error(tracker):
    tracker.step(pose=(0.0, 0.0, -math.pi / 2))
    tracker.step(pose=(0.0, 0.0, -math.pi / 2), **blob(GREEN, 100.0))
    out = tracker.step(pose=(0.0, 0.0, -math.pi / 2), **blob(GREEN, 400.0))
    assert out.state == TURN_RIGHT
    assert abs(tracker.get("turnTarget")) == pytest.approx(math.pi)
    out = tracker.step(pose=(0.0, 0.0, 3.13))  # overshot across pi: small left correction
    assert out.state == TURN_RIGHT
    assert out.w == pytest.approx(3.0 * (math.pi - 3.13))
    out = tracker.step(pose=(0.0, 0.0, -3.14))
    assert out.state == SEARCH


def test_a_sign_cannot_retrigger_before_the_robot_drove_rearm_distance(tracker):
    tracker.step(**blob(BLUE, 100.0))
    tracker.step(**blob(BLUE, 320.0))
    out = tracker.step(pose=(3.0, 0.0, math.pi / 2))
    assert out.state == SEARCH
    out = tracker.step(pose=(3.0, 0.4, math.pi / 2), **blob(GREEN, 100.0))
    assert out.state == SEARCH  # 0.4 m < rearmDistance 0.5 m
    out = tracker.step(pose=(3.0, 0.6, math.pi / 2), **blob(GREEN, 100.0))
    assert out.state == APPROACH


def test_red_sign_stops_for_good(tracker):
    tracker.step(**blob(RED, 100.0))
    out = tracker.step(**blob(RED, 300.0))
    assert out == Out(STOP, 0.0, 0.0, True)
    out = tracker.step()  # nothing in view any more: still stopped
    assert out == Out(STOP, 0.0, 0.0, True)
    out = tracker.step(**blob(BLUE, 500.0))
    assert out == Out(STOP, 0.0, 0.0, True)


def test_parameters_change_speeds_thresholds_and_heading_snapping():
    fmu = Tracker(cruiseSpeed=0.2, actionSize=150.0, turnRate=0.5, snapHeading=False)
    try:
        assert fmu.step(pose=(0.0, 0.0, 0.3)).v == 0.2
        assert fmu.get("headingRef") == pytest.approx(0.3)  # not snapped to 0
        fmu.step(pose=(0.0, 0.0, 0.3), **blob(BLUE, 100.0))
        out = fmu.step(pose=(0.0, 0.0, 0.3), **blob(BLUE, 160.0))
        assert out == Out(TURN_LEFT, 0.0, 0.5, False)
        assert fmu.get("turnTarget") == pytest.approx(0.3 + math.pi / 2)
    finally:
        fmu.close()


def test_model_description_start_values_are_the_fmu_defaults(tracker):
    for var in tracker.description.modelVariables:
        if var.causality == "parameter":
            expected = {"Real": float, "Integer": int}.get(var.type, lambda s: s == "true")(
                var.start
            )
            assert tracker.get(var.name) == expected, var.name


def test_outputs_have_no_direct_feedthrough():
    description = read_model_description(str(built_model("SignTrackingLogic.fmu")))
    assert {o.variable.name: o.dependencies for o in description.outputs} == {
        "v": [],
        "w": [],
        "stopRobot": [],
        "state": [],
    }
    names = [v.name for v in description.modelVariables if v.causality == "input"]
    assert names[:6] == [f"blobSize[{i}]" for i in (1, 2, 3)] + [f"blobX[{i}]" for i in (1, 2, 3)]
