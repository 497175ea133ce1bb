"""A DC-motor SSP as other tools write one, against the motor's exact solution (issue #33).

An SSP 2.0 system with a nested system around a model-exchange DC motor (``DCMotor2``:
``L di/dt = V - R i - k w``, ``J dw/dt = k i - b w - tau_load``, ``dphi/dt = w``), connector
units that name one unit two ways (``Nm`` on the system connectors, ``N.m`` on the FMU's),
top-level parameter connectors bound to values in other units (``12000 mV``, ``2 N.cm``) and
inline parameter values in units other than the FMU's (``500 mH``, ``20 g.m2``). With the
values converted as the standard says (SSV ``ssv:Real unit``, defined in the set's
``ssv:Units``) the motor is linear with constant inputs, so its angle has an exact solution:
``z(t) = expm(M t) z(0)`` for the augmented system ``z = [i, w, phi, 1]``.

Before the fix, fmionnx took every number as written in the FMU's unit: ``L = 500 H`` and
``J = 20 kg.m2``, a motor a thousand times slower (the issue's DC motor ran to a wrong angle
whatever the step; values with units were the cause fmionnx could reproduce here).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.frontends import load_system
from tests.ssp.conftest import SSP_NAMESPACES, write_ssp

FMU = "application/x-fmu-sharedlibrary"

#: The motor in SI units, as the SSD's values mean them.
R, L, K, J, B = 1.0, 0.5, 0.05, 0.02, 0.1
V, TAU = 12.0, 0.02


def _unit(name: str, factor: float = 1.0, **exponents: int) -> str:
    powers = " ".join(f'{base}="{power}"' for base, power in exponents.items())
    return f'<ssc:Unit name="{name}"><ssc:BaseUnit {powers} factor="{factor}"/></ssc:Unit>'


def _parameters(values: list[tuple[str, float, str]], units: str) -> str:
    entries = "".join(
        f'<ssv:Parameter name="{name}"><ssv:Real value="{value}" unit="{unit}"/></ssv:Parameter>'
        for name, value, unit in values
    )
    return (
        "<ssd:ParameterBindings><ssd:ParameterBinding><ssd:ParameterValues>"
        f'<ssv:ParameterSet version="2.0" name="values"><ssv:Parameters>{entries}'
        f"</ssv:Parameters><ssv:Units>{units}</ssv:Units></ssv:ParameterSet>"
        "</ssd:ParameterValues></ssd:ParameterBinding></ssd:ParameterBindings>"
    )


def _connector(name: str, kind: str, unit: str) -> str:
    return f'<ssd:Connector name="{name}" kind="{kind}"><ssc:Real unit="{unit}"/></ssd:Connector>'


def _connection(start: str, end: str) -> str:
    (se, sc), (ee, ec) = start.split("."), end.split(".")
    return (
        f'<ssd:Connection startElement="{se}" startConnector="{sc}" endElement="{ee}" '
        f'endConnector="{ec}"/>'
    )


def dc_motor_ssd() -> str:
    motor_values = _parameters(
        [
            ("R", 1.0, "Ohm"),
            ("L", 500.0, "mH"),
            ("k", 0.05, "N.m/A"),
            ("J", 20.0, "g.m2"),
            ("b", 0.1, "N.m.s/rad"),
        ],
        _unit("Ohm", kg=1, m=2, s=-3, A=-2)
        + _unit("mH", 0.001, kg=1, m=2, s=-2, A=-2)
        + _unit("N.m/A", kg=1, m=2, s=-2, A=-1)
        + _unit("g.m2", 0.001, kg=1, m=2)
        + _unit("N.m.s/rad", kg=1, m=2, s=-1, rad=-1),
    )
    motor = (
        f'<ssd:Component name="motor" type="{FMU}" source="resources/DCMotor2.fmu" '
        'implementation="ModelExchange"><ssd:Connectors>'
        + _connector("V", "input", "V")
        + _connector("tau_load", "input", "N.m")
        + _connector("phi", "output", "rad")
        + _connector("tau", "output", "N.m")
        + f"</ssd:Connectors>{motor_values}</ssd:Component>"
    )
    drive = (
        '<ssd:System name="drive"><ssd:Connectors>'
        + _connector("V_in", "parameter", "V")
        + _connector("load_in", "parameter", "N.m")
        + _connector("tau_out", "output", "Nm")
        + f"</ssd:Connectors><ssd:Elements>{motor}</ssd:Elements><ssd:Connections>"
        + _connection(".V_in", "motor.V")
        + _connection(".load_in", "motor.tau_load")
        + _connection("motor.tau", ".tau_out")
        + "</ssd:Connections></ssd:System>"
    )
    top_values = _parameters(
        [("U_supply", 12000.0, "mV"), ("tau_load", 2.0, "N.cm")],
        _unit("mV", 0.001, kg=1, m=2, s=-3, A=-1) + _unit("N.cm", 0.01, kg=1, m=2, s=-2),
    )
    root = (
        '<ssd:System name="dc"><ssd:Connectors>'
        + _connector("U_supply", "parameter", "V")
        + _connector("tau_load", "parameter", "Nm")
        + _connector("torque", "output", "Nm")
        + f"</ssd:Connectors>{top_values}<ssd:Elements>{drive}</ssd:Elements>"
        + "<ssd:Connections>"
        + _connection(".U_supply", "drive.V_in")
        + _connection(".tau_load", "drive.load_in")
        + _connection("drive.tau_out", ".torque")
        + "</ssd:Connections></ssd:System>"
    )
    units = (
        _unit("Nm", kg=1, m=2, s=-2)
        + _unit("N.m", kg=1, m=2, s=-2)
        + _unit("V", kg=1, m=2, s=-3, A=-1)
        + _unit("rad", rad=1)
    )
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<ssd:SystemStructureDescription {SSP_NAMESPACES} name="dc_motor" version="2.0">'
        f"{root}<ssd:Units>{units}</ssd:Units>"
        '<ssd:DefaultExperiment startTime="0" stopTime="1"/>'
        "</ssd:SystemStructureDescription>"
    )


def _expm(matrix: np.ndarray) -> np.ndarray:
    """exp(matrix) by scaling and squaring a Taylor series (numpy only; small matrices)."""
    norm = float(np.abs(matrix).sum(axis=1).max())
    squarings = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0 else 0
    scaled = matrix / 2.0**squarings
    result = np.eye(len(matrix))
    term = np.eye(len(matrix))
    for n in range(1, 30):
        term = term @ scaled / n
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


def exact_angle(t: float) -> float:
    """phi(t) of the motor from rest: z' = M z with z = [i, w, phi, 1]."""
    m = np.array(
        [
            [-R / L, -K / L, 0.0, V / L],
            [K / J, -B / J, 0.0, -TAU / J],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0],
        ]
    )
    return float((_expm(m * t) @ np.array([0.0, 0.0, 0.0, 1.0]))[2])


@pytest.fixture
def dc_motor_ssp(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    return write_ssp(
        tmp_path / "dc_motor.ssp",
        {"SystemStructure.ssd": dc_motor_ssd(), "resources/DCMotor2.fmu": fixture_fmu("DCMotor2")},
    )


def test_values_with_units_are_converted_to_the_models_units(dc_motor_ssp: Path) -> None:
    bag = DiagnosticBag()
    assert load_system(dc_motor_ssp, bag).spec is not None, list(bag)
    compiled = fmionnx.load(dc_motor_ssp).compiled
    values = {p.port: p.value[0] for p in compiled.component("drive.motor").parameters}
    assert values == pytest.approx(
        {"R": R, "L": L, "k": K, "J": J, "b": B, "V": V, "tau_load": TAU}, rel=1e-12
    )


@pytest.mark.parametrize("step", [0.01, 0.001])
def test_the_motor_angle_is_the_exact_solution_at_any_step(dc_motor_ssp: Path, step: float) -> None:
    result = fmionnx.load(dc_motor_ssp, step=step).run()
    assert result.time[-1] == pytest.approx(1.0)
    # CVode at the FMU's tolerance (1e-10): far closer than the 0.6 % error
    assert result["drive.motor.phi"][-1] == pytest.approx(exact_angle(1.0), rel=1e-6)
    assert result["drive.motor.tau"][-1] > 0.0
