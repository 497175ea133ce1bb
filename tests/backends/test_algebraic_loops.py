"""Algebraic loops solved by iteration (``run.algebraic_loops``), against analytic solutions.

The loops are real parts: the Gain test FMU (FMI 2 co-simulation, ``y = k*u``, direct
feedthrough, ``canGetAndSetFMUstate``) and an ONNX model run by onnxruntime. With the gains
``k1``, ``k2`` and the reference ``r`` carried by a connection's offset (``u1 = r - y2``), the
loop ``y1 = k1*u1``, ``y2 = k2*y1`` has the solution ``y1 = k1*r / (1 + k1*k2)``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper

import fmionnx
from fmionnx.core.runner import Runner, StateSaving, Wiring, get_output, set_input
from fmionnx.core.types import Component
from fmionnx.kinds.registry import make_runner
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunStatus
from tests.backends.conftest import SystemWriter

R = 1.0


def _gain_loop(
    gain: Path,
    k1: float,
    k2: float,
    solver: str,
    *,
    extra: str = "",
) -> str:
    return f"""
fmionnx: 1
name: gain_loop
run: {{stop: 0.3, step: 0.1, algebraic_loops: {{solver: {solver}{extra}}}}}
components:
  a: {{kind: fmu, path: {gain}, parameters: {{k: {k1}}}}}
  b: {{kind: fmu, path: {gain}, parameters: {{k: {k2}}}}}
connections:
  - {{from: b.y, to: a.u, factor: -1, offset: {R}}}
  - a.y -> b.u
record: [a.u, a.y, b.y]
"""


def _half(path: Path, element: int = TensorProto.DOUBLE) -> Path:
    """An ONNX model computing ``y = 0.5 * x`` (double precision unless ``element`` says)."""
    graph = helper.make_graph(
        [helper.make_node("Mul", ["x", "half"], ["y"])],
        "half",
        [helper.make_tensor_value_info("x", element, [1])],
        [helper.make_tensor_value_info("y", element, [1])],
        [helper.make_tensor("half", element, [1], [0.5])],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


@pytest.mark.parametrize("solver", ["fixed-point", "newton"])
def test_two_gain_fmus_in_a_loop_reach_the_analytic_solution(
    fixture_fmu, write_system: SystemWriter, solver: str
) -> None:
    k1, k2 = 2.0, 0.25
    system = fmionnx.load(write_system(_gain_loop(fixture_fmu("Gain"), k1, k2, solver)))
    (loop,) = system.compiled.loops
    assert loop.members == ("a", "b")
    assert [str(t) for t in loop.tears] == ["a.u"]
    result = system.run(isolate="none")
    assert result.status is RunStatus.COMPLETED, result.error
    y1 = k1 * R / (1 + k1 * k2)
    # the row at the start time holds the initial outputs; every step solves the loop
    np.testing.assert_allclose(result["a.y"][1:], y1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result["b.y"][1:], k2 * y1, rtol=0, atol=1e-9)
    # the input recorded at t_n is the one the kept iteration of the step from t_n used:
    # exactly what made the output at t_n+1, and the loop's value to the tolerance
    np.testing.assert_allclose(result["a.y"][1:], k1 * result["a.u"][:-1], rtol=0, atol=0)
    np.testing.assert_allclose(result["a.u"][:-1], R - result["b.y"][1:], rtol=0, atol=1e-9)


def test_newton_solves_a_loop_that_fixed_point_iteration_cannot(
    fixture_fmu, write_system: SystemWriter
) -> None:
    k1, k2 = 2.0, 3.0  # |k1*k2| > 1: the plain fixed-point iteration diverges
    master = Master(
        fmionnx.load(write_system(_gain_loop(fixture_fmu("Gain"), k1, k2, "newton"))).compiled
    )
    result = master.run()
    assert result.status is RunStatus.COMPLETED, result.error
    np.testing.assert_allclose(result["a.y"][1:], k1 * R / (1 + k1 * k2), atol=1e-9)
    # linear: one Newton update, perhaps a second for the finite-difference error; later
    # points start from the solution they hold and need none
    assert 1 <= master.loops[0].peak_iterations <= 2
    assert master.loops[0].iterations == 0


def test_relaxation_makes_the_fixed_point_iteration_converge(
    fixture_fmu, write_system: SystemWriter
) -> None:
    # x <- x + w*(r - k1*k2*x - x) contracts for 0 < w < 2/(1 + k1*k2) = 2/7
    text = _gain_loop(fixture_fmu("Gain"), 2.0, 3.0, "fixed-point", extra=", relaxation: 0.14")
    result = fmionnx.load(write_system(text)).run(isolate="none")
    assert result.status is RunStatus.COMPLETED, result.error
    np.testing.assert_allclose(result["a.y"][1:], 2.0 / 7.0, rtol=0, atol=1e-9)


def test_a_loop_that_does_not_converge_is_a_fault_naming_it(
    fixture_fmu, write_system: SystemWriter
) -> None:
    text = _gain_loop(fixture_fmu("Gain"), 2.0, 3.0, "fixed-point", extra=", max_iterations: 5")
    result = fmionnx.load(write_system(text)).run(isolate="none")
    assert result.status is RunStatus.FAULT
    message = str(result.error)
    assert message.startswith(
        "algebraic loop b.y -> a.u -> a.y -> b.u -> b.y (components `a`, `b`) at t=0 s: "
        "did not converge in 5 iterations (fixed-point, relaxation 1)"
    )
    assert "tolerance 1e-10" in message
    assert "tear variables: a.u" in message
    residual = float(message.split("is ")[1].split(",", maxsplit=1)[0])
    assert residual > 1  # diverging: the error grows six-fold per iteration


def test_a_singular_newton_jacobian_is_a_fault(fixture_fmu, write_system: SystemWriter) -> None:
    # k1*k2 = -1: u1 = r + u1 has no solution; F(x) = r is constant, its Jacobian zero
    result = fmionnx.load(write_system(_gain_loop(fixture_fmu("Gain"), 1.0, -1.0, "newton"))).run(
        isolate="none"
    )
    assert result.status is RunStatus.FAULT
    assert "the Jacobian of its tear values is singular" in str(result.error)


@pytest.mark.parametrize("solver", ["fixed-point", "newton"])
def test_a_loop_through_an_onnx_model_reaches_the_analytic_solution(
    fixture_fmu, write_system: SystemWriter, tmp_path: Path, solver: str
) -> None:
    half = _half(tmp_path / "half.onnx")
    text = f"""
fmionnx: 1
name: onnx_loop
run: {{stop: 0.2, step: 0.1, algebraic_loops: {{solver: {solver}}}}}
components:
  net: {{kind: onnx, path: {half}}}
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: 1.0}}}}
connections:
  - gain.y -> net.x
  - {{from: net.y, to: gain.u, factor: -1, offset: {R}}}
"""
    system = fmionnx.load(write_system(text))
    (loop,) = system.compiled.loops
    assert loop.members == ("net", "gain")  # declaration order; net reads gain's newer value
    assert [str(t) for t in loop.tears] == ["net.x"]
    result = system.run(isolate="none")
    assert result.status is RunStatus.COMPLETED, result.error
    y = R / (1 + 0.5)  # gain.y = 1 * (r - 0.5 * gain.y)
    np.testing.assert_allclose(result["gain.y"][1:], y, rtol=0, atol=1e-9)
    np.testing.assert_allclose(result["net.y[0]"][1:], 0.5 * y, rtol=0, atol=1e-9)


def test_an_fmu_runner_restores_its_state_and_outputs(fixture_fmu, tmp_path: Path) -> None:
    component = fmionnx.load(fixture_fmu("Gain")).compiled.components[0]
    runner = make_runner(component, Wiring())
    assert isinstance(runner, StateSaving)
    runner.instantiate()
    try:
        runner.setup(0.0, 1.0)
        set_input(runner, "u", 1.0)
        runner.save_state(0.0)
        runner.step(0.0, 0.1)
        assert get_output(runner, "y") == 2.0
        runner.restore_state(0.0)
        assert get_output(runner, "y") == 0.0  # the saved point's output
        set_input(runner, "u", 3.0)
        runner.step(0.0, 0.1)
        assert get_output(runner, "y") == 6.0
    finally:
        runner.terminate()


class _NoRollback:
    """A runner passed through without its state saving."""

    def __init__(self, inner: Runner) -> None:
        self._inner = inner
        self.component = inner.component
        self.lazy_outputs = inner.lazy_outputs

    def __getattr__(self, name: str) -> Any:
        if name in ("save_state", "restore_state"):
            raise AttributeError(name)
        return getattr(self._inner, name)


def test_a_member_whose_runner_cannot_roll_back_is_a_fault_before_the_first_step(
    fixture_fmu, write_system: SystemWriter
) -> None:
    compiled = fmionnx.load(
        write_system(_gain_loop(fixture_fmu("Gain"), 2.0, 0.25, "fixed-point"))
    ).compiled

    def factory(component: Component, wiring: Wiring) -> Runner:
        return _NoRollback(make_runner(component, wiring))  # type: ignore[return-value]

    result = Master(compiled, runner_factory=factory).run()
    assert result.status is RunStatus.FAULT
    assert str(result.error).startswith("component `a` is part of the algebraic loop")
    assert "cannot save and restore its state" in str(result.error)
    assert result.steps_done == 0


@pytest.mark.parametrize("solver", ["fixed-point", "newton"])
def test_a_float32_loop_converges_to_a_tolerance_float32_can_meet(
    fixture_fmu, write_system: SystemWriter, tmp_path: Path, solver: str
) -> None:
    # the iterate is rounded to the float32 input it is written to, and Newton's difference
    # step is sized for float32, so the iteration converges as far as float32 carries
    half = _half(tmp_path / "half32.onnx", TensorProto.FLOAT)
    text = f"""
fmionnx: 1
name: float32_loop
run: {{stop: 0.2, step: 0.1, algebraic_loops: {{solver: {solver}, tolerance: 1e-6}}}}
components:
  net: {{kind: onnx, path: {half}}}
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{k: 1.0}}}}
connections:
  - gain.y -> net.x
  - {{from: net.y, to: gain.u, factor: -1, offset: {R}}}
"""
    result = fmionnx.load(write_system(text)).run(isolate="none")
    assert result.status is RunStatus.COMPLETED, result.error
    np.testing.assert_allclose(result["gain.y"][1:], R / 1.5, rtol=0, atol=1e-6)


@pytest.mark.parametrize("solver", ["fixed-point", "newton"])
def test_isolated_members_save_and_restore_through_their_process(
    fixture_fmu, write_system: SystemWriter, solver: str
) -> None:
    # `fmionnx run` isolates FMUs by default: their state is saved and restored in the child
    from fmionnx.runtime.result import RunOptions

    system = fmionnx.load(write_system(_gain_loop(fixture_fmu("Gain"), 2.0, 0.25, solver)))
    plain = system.run(isolate="none")
    isolated = system.run(options=RunOptions(isolate=frozenset({"a", "b"})))
    assert isolated.status is RunStatus.COMPLETED, isolated.error
    assert isolated["a.y"][-1] == pytest.approx(2.0 * R / 1.5, abs=1e-9)
    for name, values in plain.signals.items():
        assert np.array_equal(values, isolated.signals[name]), name
