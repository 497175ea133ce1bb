"""The native kernel's reach (issue 14): FMI 3 co-simulation FMUs, float32, integer and
boolean ports, every conversion the Python transfer path makes; bit-identical to it.

Each system runs twice, natively and with ``FMIONNX_NATIVE=0``, and every recorded signal is
compared byte for byte. ``Types3`` (an FMI 3 fixture with one input and one output of every
numeric FMI 3 type), ``Vector3`` (FMI 3 arrays, Int32) and ``Count2`` (FMI 2 Integer input and
output) are built from C by the fixture machinery.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

import fmionnx
from fmionnx.kinds.fmu.build import build_fmu
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from tests.conftest import FIXTURES, REPO, built_model


@pytest.fixture(autouse=True)
def _installed_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("FMIONNX_NATIVE", raising=False)


def _both_ways(
    path: Path, monkeypatch: pytest.MonkeyPatch, **run: object
) -> tuple[RunResult, RunResult]:
    results = []
    for setting in ("1", "0"):
        with monkeypatch.context() as patch:
            patch.setenv("FMIONNX_NATIVE", setting)
            results.append(fmionnx.load(path).run(isolate="none", **run))  # type: ignore[arg-type]
    native, python = results
    assert python.details["native"] is False
    assert python.details["native_reason"] == "disabled by FMIONNX_NATIVE=0"
    return native, python


def _assert_bit_identical(native: RunResult, python: RunResult) -> None:
    assert native.status is python.status
    assert native.steps_done == python.steps_done
    assert native.ended_by == python.ended_by
    assert str(native.error) == str(python.error)
    assert list(native.signals) == list(python.signals)
    for name, values in python.signals.items():
        assert native.signals[name].tobytes() == values.tobytes(), name


#: Why ``d`` keeps the Python path (its first connection).
SCALED_INTO_INTEGER = (
    "the connection `b.y_i8 -> d.u_i8` computes factor*x + offset in float64 and turns it "
    "into int8 (numpy's result for a float outside the integer's range depends on the platform)"
)


def _types_system(fixture_fmu, write_system, *, stop: float = 3.0, params: str = "") -> Path:
    """FMI 3 and FMI 2 FMUs exchanging every numeric type, with conversions between them."""
    types3, vector3, count2 = fixture_fmu("Types3"), fixture_fmu("Vector3"), fixture_fmu("Count2")
    return write_system(
        f"""
fmionnx: 1
name: reach
run: {{stop: {stop}, step: 0.01}}
components:
  src:
    kind: signal
    outputs:
      s: {{sine: {{frequency: 0.7, amplitude: 3.3}}}}
      k: {{step: {{time: 1.0, initial: 0, final: 1}}}}
      r: {{ramp: {{slope: 0.37}}}}
  v: {{kind: fmu, path: {vector3}, parameters: {{k: 1.7}}}}
  a: {{kind: fmu, path: {types3}{params}}}
  b: {{kind: fmu, path: {types3}}}
  c: {{kind: fmu, path: {types3}}}
  n: {{kind: fmu, path: {count2}}}
  d: {{kind: fmu, path: {types3}}}
connections:
  - {{from: b.y_f64, to: v.u, factor: 0.5, offset: 0.25}}
  - v.y -> a.u_f64
  - src.s -> a.u_f32
  - src.k -> a.u_bool
  - b.y_i8 -> a.u_i8
  - b.y_u8 -> a.u_u8
  - b.y_i16 -> a.u_i16
  - b.y_u16 -> a.u_u16
  - n.m -> a.u_i32
  - b.y_u32 -> a.u_u32
  - b.y_i64 -> a.u_i64
  - b.y_u64 -> a.u_u64
  - a.y_f64 -> b.u_f64
  - {{from: a.y_f32, to: b.u_f32, factor: 0.1, offset: 0.3}}
  - a.y_i8 -> b.u_i8
  - a.y_u8 -> b.u_u8
  - a.y_i16 -> b.u_i16
  - a.y_u16 -> b.u_u16
  - a.y_i32 -> b.u_i32
  - a.y_u32 -> b.u_u32
  - a.y_i64 -> b.u_i64
  - a.y_u64 -> b.u_u64
  - a.y_bool -> n.b
  - n.nb -> b.u_bool
  - {{from: a.y_f64, to: c.u_f64, factor: 2.5, offset: -1}}
  - a.y_i64 -> c.u_i16
  - a.y_u64 -> c.u_f32
  - a.y_bool -> c.u_u8
  - a.y_i8 -> c.u_bool
  - a.y_u32 -> c.u_i64
  - v.count -> c.u_u64
  - a.y_i8 -> c.u_i8
  - {{from: b.y_i8, to: d.u_i8, factor: 0.5}}
  - {{from: a.y_f32, to: c.u_u16}}
  - a.y_f32 -> n.u
  - a.y_i16 -> n.n
  - src.r -> d.u_i32
  - {{from: b.y_u8, to: 'd.u_f64[1]', factor: 0.3, offset: 0.1}}
record: [v.y, v.count, a.y_f64, a.y_f32, a.y_i8, a.y_u8, a.y_i16, a.y_u16, a.y_i32, a.y_u32,
  a.y_i64, a.y_u64, a.y_bool, b.u_f32, b.y_f32, c.u_f64, c.u_i16, c.u_f32, c.u_u8, c.u_bool,
  c.u_i64, c.u_u64, c.u_i8, c.u_u16, c.y_u64, n.u, n.n, n.y, n.m, n.b, n.nb, b.u_bool, d.u_i32, d.u_f64, d.u_i8,
  d.y_i32]
"""
    )


def test_fmi3_and_integer_ports_are_stepped_natively_and_bit_identically(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    native, python = _both_ways(_types_system(fixture_fmu, write_system), monkeypatch)
    assert native.status is RunStatus.COMPLETED
    assert native.details["native"] is True
    # every FMU but c and d, which turn floats into integers
    assert native.details["native_components"] == 4
    assert native.details["native_python.src"] == (
        "a signal component (only FMI co-simulation FMUs run natively)"
    )
    assert native.details["native_python.c"] == (
        "the connection `a.y_f32 -> c.u_u16` turns float32 into uint16 (numpy's result for a "
        "float outside the integer's range depends on the platform)"
    )
    assert native.details["native_python.d"] == SCALED_INTO_INTEGER
    assert not any(key.startswith("native_python.") for key in python.details)
    _assert_bit_identical(native, python)
    # the signals really move, wrap and convert
    assert len(set(native["a.y_i8"].tolist())) > 100  # int8 wrapped around
    assert len(set(native["n.m"].tolist())) > 100
    assert {0.0, 1.0} <= set(native["c.u_bool"].tolist())
    assert {0.0, 1.0} == set(native["n.nb"].tolist())  # FMI 2 Boolean in and out
    assert len(set(native["c.u_f32"].tolist())) > 100
    assert len(set(native["b.u_f32"].tolist())) > 100


def test_a_group_without_the_float_to_integer_connection_takes_every_fmu(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    text = _types_system(fixture_fmu, write_system).read_text(encoding="utf-8")
    text = text.replace("  - {from: a.y_f32, to: c.u_u16}\n", "")
    text = text.replace("  - src.r -> d.u_i32\n", "")
    path = write_system(text.replace("c.u_u16, ", "").replace("d.u_i32, ", ""))
    native, python = _both_ways(path, monkeypatch)
    assert native.details["native_components"] == 5
    assert [k for k in native.details if k.startswith("native_python.")] == [
        "native_python.src",
        "native_python.d",
    ]
    # an integer destination of factor*x + offset gets a float: kept in Python as well
    assert native.details["native_python.d"] == SCALED_INTO_INTEGER
    _assert_bit_identical(native, python)


@pytest.mark.parametrize(
    ("params", "status", "message"),
    [
        (", parameters: {failAt: 0.5}", RunStatus.FAULT, r"component `a` at t=0\.49 s: fmi3DoStep"),
        (", parameters: {stopAt: 0.5}", RunStatus.COMPLETED, None),
    ],
)
def test_fmi3_fault_and_termination_inside_a_group_match_the_python_path(
    fixture_fmu,
    write_system,
    monkeypatch: pytest.MonkeyPatch,
    params: str,
    status: RunStatus,
    message: str | None,
) -> None:
    path = _types_system(fixture_fmu, write_system, stop=1.0, params=params)
    native, python = _both_ways(path, monkeypatch)
    assert native.details["native_components"] == 4
    assert native.status is status
    _assert_bit_identical(native, python)
    if message is None:
        assert native.ended_by is not None
        assert (native.ended_by.component, native.ended_by.time) == ("a", 0.5)
        assert native.steps_done == 50
    else:
        assert re.match(message + r" returned Error \(FMU log: .*failAt reached", str(native.error))
        assert native.steps_done == 49


def test_an_fmu_with_clocks_keeps_the_python_path_and_says_why(
    write_system, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """An FMI 3 FMU declaring a clock needs Event Mode, which the kernel never enters."""
    source = tmp_path / "Clocked3"
    shutil.copytree(FIXTURES / "fmus" / "Types3", source)
    description = source / "modelDescription.xml"
    text = description.read_text(encoding="utf-8")
    text = text.replace('hasEventMode="false"', 'hasEventMode="true"')
    text = text.replace(
        '    <Int32 name="count"',
        '    <Clock name="tick" valueReference="900" causality="output" '
        'intervalVariability="triggered"/>\n    <Int32 name="count"',
    )
    description.write_text(text, encoding="utf-8")
    fmu = build_fmu(source, tmp_path / "Clocked3.fmu")
    path = write_system(
        f"""
fmionnx: 1
name: clocked
run: {{stop: 0.2, step: 0.01}}
components:
  e: {{kind: fmu, path: {fmu}}}
  f: {{kind: fmu, path: {fmu}}}
connections:
  - e.y_i32 -> f.u_i32
  - f.y_bool -> e.u_bool
record: [e.y_i32, f.y_i32, e.y_bool]
"""
    )
    native, python = _both_ways(path, monkeypatch)
    assert native.details["native"] is False
    assert native.details["native_reason"] == "no component can run natively"
    reason = (
        "declares the FMI 3 clock(s) `tick`, which need Event Mode: the Python path runs it "
        "(without Event Mode, its output clocks ignored)"
    )
    assert native.details["native_python.e"] == native.details["native_python.f"] == reason
    _assert_bit_identical(native, python)
    assert len(set(native["f.y_i32"].tolist())) > 10


def test_the_reference_tracker_with_float32_inputs_runs_natively_bit_identically(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The tracker's blobX/blobSize come from the detector's float32 outputs (2 s of the
    reference scenario; its full results.csv hash: ``test_sign_follower.py``)."""
    built_model("SignTrackingLogic.fmu")
    system = REPO / "systems" / "sign_follower.yaml"
    native, python = _both_ways(system, monkeypatch, stop_time=2.0)
    assert native.details["native_components"] == 2  # odometry and the tracker
    assert "native_python.tracker" not in native.details
    assert native.details["native_python.detector"] == (
        "an onnx component (only FMI co-simulation FMUs run natively)"
    )
    _assert_bit_identical(native, python)
    assert len(set(native["detector.blobSize[0,0]"].tolist())) > 5  # the sign is seen


def test_model_exchange_and_isolated_fmus_keep_the_python_path_with_their_reasons(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    gain = fixture_fmu("Gain")
    path = write_system(
        f"""
fmionnx: 1
name: mixed
run: {{stop: 0.05, step: 0.01}}
components:
  g0: {{kind: fmu, path: {gain}, parameters: {{u: 1.5}}}}
  g1: {{kind: fmu, path: {gain}, interface: me}}
  g2: {{kind: fmu, path: {gain}}}
  g3: {{kind: fmu, path: {gain}}}
connections:
  - g0.y -> g1.u
  - g1.y -> g2.u
  - g2.y -> g3.u
record: [g3.y]
"""
    )
    result = fmionnx.load(path).run(options=RunOptions(isolate=frozenset({"g2"})))
    assert result.status is RunStatus.COMPLETED
    assert (result.details["native_groups"], result.details["native_components"]) == (2, 2)
    assert result.details["native_python.g1"] == (
        "a model-exchange FMU (integrated in Python between communication points)"
    )
    assert result.details["native_python.g2"] == (
        "runs in a child process (--isolate), stepped there by the native kernel"
    )
    assert result["g3.y"][-1] == 1.5 * 2**4
    # A model-exchange FMU's child integrates it in Python (the kernel steps co-simulation).
    both = fmionnx.load(path).run(options=RunOptions(isolate=frozenset({"g1", "g2"})))
    assert both.details["native_python.g1"] == "runs in a child process (--isolate)"
    assert both["g3.y"][-1] == 1.5 * 2**4
