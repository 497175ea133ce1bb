"""The `signal` kind: every waveform's values, tables, and signals driving real FMUs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx import api
from fmionnx.core.runner import Runner, get_output
from fmionnx.core.types import Causality, DType
from fmionnx.kinds.registry import make_runner
from fmionnx.kinds.signal.kind import SIGNAL_KIND
from tests.conftest import REPO


def _runner(tmp_path: Path, entry: str, csv: str | None = None) -> Runner:
    """The runner of component `s` (the given entry), instantiated and set up at t = 0."""
    if csv is not None:
        (tmp_path / "table.csv").write_text(csv, encoding="utf-8")
    system = tmp_path / "system.yaml"
    system.write_text(
        f"fmionnx: 1\nname: values\nrun: {{stop: 10, step: 0.5}}\ncomponents:\n  s: {entry}\n",
        encoding="utf-8",
    )
    result = api.compile_system(system)
    assert result.system is not None, result.diagnostics
    runner = make_runner(result.system.component("s"))
    runner.instantiate()
    runner.setup(0.0, 10.0)
    return runner


def _at(runner: Runner, port: str, t: float) -> float:
    """The value of ``port`` after a step that ends exactly at ``t`` (0 + t == t)."""
    runner.step(0.0, t)
    return float(get_output(runner, port))


def _initial(runner: Runner, port: str) -> float:
    return float(get_output(runner, port))


WAVEFORMS = "{kind: signal, outputs: {c: {constant: 1.5}, st: {step: {time: 2, initial: -1, final: 0.3}}, ru: {ramp: {time: 1, initial: 2, slope: 0.5}}, rt: {ramp: {time: 1, final: 4, duration: 2}}, si: {sine: {amplitude: 2, frequency: 0.25, offset: 1}}, ph: {sine: {frequency: 0.5, phase: 1.5707963267948966}}}}"


@pytest.mark.parametrize(
    ("port", "expected"),
    [
        ("c", {0.0: 1.5, 1.0: 1.5, 7.25: 1.5}),
        # a step at T is already final at t = T (FMI/Simulink convention)
        ("st", {0.0: -1.0, 1.999: -1.0, 2.0: 0.3, 5.0: 0.3}),
        ("ru", {0.0: 2.0, 1.0: 2.0, 1.5: 2.25, 3.0: 3.0}),
        ("rt", {0.0: 0.0, 1.0: 0.0, 1.5: 1.0, 2.0: 2.0, 3.0: 4.0, 9.0: 4.0}),
        ("si", {0.0: 1.0, 1.0: 3.0, 3.0: -1.0}),
        ("ph", {0.0: 1.0, 1.0: -1.0}),
    ],
)
def test_every_waveform_has_its_value_at_chosen_times(
    tmp_path: Path, port: str, expected: dict[float, float]
) -> None:
    runner = _runner(tmp_path, WAVEFORMS)
    assert _initial(runner, port) == expected[0.0]
    for t, value in expected.items():
        assert _at(runner, port, t) == value, (port, t)


def test_sine_is_offset_plus_amplitude_times_sine_of_two_pi_f_t_plus_phase(
    tmp_path: Path,
) -> None:
    runner = _runner(
        tmp_path,
        "{kind: signal, outputs: {v: {sine: {amplitude: 0.5, frequency: 0.2, phase: 0.3, offset: -1}}}}",
    )
    for t in (0.1, 0.7, 2.3, 9.9):
        assert _at(runner, "v", t) == -1 + 0.5 * math.sin(2 * math.pi * 0.2 * t + 0.3)


TABLE = "time,a,b\n1,0,10\n\n2,4,20\n4, 0 ,20\n"


@pytest.mark.parametrize(
    ("interpolation", "expected"),
    [
        # before the first row and after the last the end values are held
        (
            "linear",
            {0.0: (0, 10), 1.0: (0, 10), 1.5: (2, 15), 3.0: (2, 20), 4.0: (0, 20), 9.0: (0, 20)},
        ),
        (
            "hold",
            {0.0: (0, 10), 1.5: (0, 10), 2.0: (4, 20), 3.999: (4, 20), 4.0: (0, 20), 9.0: (0, 20)},
        ),
    ],
)
def test_table_interpolates_between_rows_and_holds_the_ends(
    tmp_path: Path, interpolation: str, expected: dict[float, tuple[float, float]]
) -> None:
    entry = f"{{kind: signal, path: table.csv, interpolation: {interpolation}}}"
    runner = _runner(tmp_path, entry, TABLE)
    assert (_initial(runner, "a"), _initial(runner, "b")) == expected[0.0]
    for t, (a, b) in expected.items():
        runner.step(0.0, t)
        assert (float(get_output(runner, "a")), float(get_output(runner, "b"))) == (a, b), t


def test_linear_is_the_default_interpolation(tmp_path: Path) -> None:
    runner = _runner(tmp_path, "{kind: signal, path: table.csv}", TABLE)
    assert _at(runner, "a", 1.25) == 1.0


def test_table_ports_are_the_value_columns(tmp_path: Path) -> None:
    table = tmp_path / "profile.csv"
    table.write_text("t,speed,turn\n0,1,2\n1,3,4\n", encoding="utf-8")
    interface = SIGNAL_KIND.read_interface(table, None)
    assert [(p.name, p.causality, p.dtype, p.shape, p.depends_on) for p in interface.ports] == [
        ("speed", Causality.OUTPUT, DType.FLOAT64, (), ()),
        ("turn", Causality.OUTPUT, DType.FLOAT64, (), ()),
    ]
    assert dict(interface.facts) == {"rows": "2", "firstTime": "0.0", "lastTime": "1.0"}
    assert len(interface.content_hash) == 64


def _system(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_an_edge_on_the_time_grid_is_not_moved_by_rounding(tmp_path: Path) -> None:
    """With step 0.1, t + h at the 44th step is 4.3999999999999995, not 4.4."""
    assert 43 * 0.1 + 0.1 < 4.4
    (tmp_path / "table.csv").write_text("time,a\n0,0\n4.4,1\n", encoding="utf-8")
    path = _system(
        tmp_path,
        "fmionnx: 1\nname: grid\nrun: {stop: 5, step: 0.1}\ncomponents:\n"
        "  s: {kind: signal, outputs: {v: {step: {time: 4.4}}}}\n"
        "  t: {kind: signal, path: table.csv, interpolation: hold}\n"
        "record: [s.v, t.a]\n",
    )
    result = fmionnx.load(path).run(isolate="none")
    expected = (np.arange(51) >= 44).astype(float)
    np.testing.assert_array_equal(result["s.v"], expected)
    np.testing.assert_array_equal(result["t.a"], expected)


def test_a_signal_drives_a_gain_fmu(tmp_path: Path, fixture_fmu) -> None:
    path = _system(
        tmp_path,
        f"""\
fmionnx: 1
name: driven
run: {{stop: 2, step: 0.1}}
components:
  stim:
    kind: signal
    outputs:
      v: {{sine: {{amplitude: 0.5, frequency: 0.25}}, unit: m}}
      w: {{step: {{time: 1, initial: 2, final: -3}}}}
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: 3.0}}}}
connections:
  - stim.v -> gain.u
  - stim.w -> gain.v[1]
record: [stim.v, stim.w, gain.y, gain.w]
""",
    )
    first = fmionnx.load(path).run(isolate="none")
    again = fmionnx.load(path).run(isolate="none")
    time = first.time
    # after each step the signal holds its value at the step's end, the gain k times it
    assert first["stim.v"][0] == 0.0
    np.testing.assert_allclose(
        first["stim.v"], 0.5 * np.sin(2 * np.pi * 0.25 * time), rtol=0, atol=1e-15
    )
    np.testing.assert_array_equal(first["stim.w"], np.where(time >= 1.0, -3.0, 2.0))
    np.testing.assert_array_equal(first["gain.y"][1:], 3.0 * first["stim.v"][1:])
    np.testing.assert_array_equal(first["gain.w[1]"][1:], 3.0 * first["stim.w"][1:])
    for name, values in first.signals.items():
        np.testing.assert_array_equal(again.signals[name], values, err_msg=name)


def test_a_table_drives_an_integrator_fmu(tmp_path: Path, fixture_fmu) -> None:
    (tmp_path / "rate.csv").write_text("time,rate\n0,2\n10,2\n", encoding="utf-8")
    path = _system(
        tmp_path,
        f"""\
fmionnx: 1
name: integrated
run: {{stop: 1, step: 0.01}}
components:
  rate: {{kind: signal, path: rate.csv}}
  integ: {{kind: fmu, path: {fixture_fmu("Integrator")}}}
connections:
  - rate.rate -> integ.u
record: [rate.rate, integ.x]
""",
    )
    result = fmionnx.load(path).run(isolate="none")
    np.testing.assert_array_equal(result["rate.rate"], np.full(101, 2.0))
    np.testing.assert_allclose(result["integ.x"], 2.0 * result.time, rtol=0, atol=1e-9)


def test_the_open_loop_example_compiles() -> None:
    result = api.compile_system(REPO / "systems" / "open_loop.yaml")
    assert result.ok, result.diagnostics
    assert result.system is not None
    assert result.system.component("command").kind == "signal"
