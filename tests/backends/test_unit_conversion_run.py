"""A run converts units on the way: km/h into m/s, mm into a real FMU's m, degC into K.

The values received are checked against values computed by hand.
"""

from __future__ import annotations

import math
import shutil

import pytest

import fmionnx
from tests.compile.test_unit_check import write_identity_onnx
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: converted
run: {stop: 0.05, step: 0.01}
components:
  sig:
    kind: signal
    outputs:
      speed: {constant: 90, unit: km/h}
      temp: {constant: 20, unit: degC}
      angle: {ramp: {slope: 3600}, unit: deg}
      length: {constant: 1500, unit: mm}
  net:
    kind: onnx
    path: identity.onnx
    units: {x_a: m/s, x_b: K, x_c: rad, y_a: m/s}
  gain: {kind: fmu, path: Gain.fmu, parameters: {k: 2, v: [0, 0, 0]}}
connections:
  - sig.speed -> net.x_a
  - sig.temp -> net.x_b
  - sig.angle -> net.x_c
  - sig.length -> gain.u
record: [net.y_a, net.y_b, net.y_c, gain.y]
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[float]]:
    folder = tmp_path_factory.mktemp("units")
    write_identity_onnx(folder / "identity.onnx", "abc")
    shutil.copy(build_fixture_fmu("Gain"), folder / "Gain.fmu")
    (folder / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    result = fmionnx.load(folder / "system.yaml").run(isolate="none")
    columns = {"time": list(result.time)}
    columns.update({name: list(values) for name, values in result.signals.items()})
    return columns


def test_a_km_per_h_output_reaches_an_m_per_s_input_converted(
    run: dict[str, list[float]],
) -> None:
    # 90 km/h = 90 * 1000 m / 3600 s = 25 m/s.
    assert run["net.y_a[0]"][-1] == pytest.approx(25.0, rel=1e-15)


def test_celsius_reaches_a_kelvin_input_with_its_offset(run: dict[str, list[float]]) -> None:
    # 20 degC = 20 + 273.15 K.
    assert run["net.y_b[0]"][-1] == pytest.approx(293.15, rel=1e-15)


def test_degrees_reach_a_radian_input_at_every_step(run: dict[str, list[float]]) -> None:
    # A ramp of 3600 deg/s: t * 3600 deg = t * 20 pi rad.
    times = run["time"]
    for t, value in zip(times, run["net.y_c[0]"], strict=True):
        assert value == pytest.approx(t * 20.0 * math.pi, rel=1e-12, abs=1e-12)


def test_millimetres_reach_the_fmus_metre_input(run: dict[str, list[float]]) -> None:
    # 1500 mm = 1.5 m; the Gain FMU outputs k * u = 2 * 1.5 m.
    assert run["gain.y"][-1] == pytest.approx(3.0, rel=1e-15)
