"""The kinds that declare ``EVALUATED_AT_START`` are exactly those whose runners evaluate at
the start time (issue #34): the ROS 2 schedule reads the capability, the backends the runner."""

from __future__ import annotations

from fmionnx.core.runner import StartEvaluating
from fmionnx.kinds.base import EVALUATED_AT_START
from fmionnx.kinds.fmu.runner import FmuRunner
from fmionnx.kinds.mujoco.runner import MujocoRunner
from fmionnx.kinds.onnx.runner import OnnxRunner
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.kinds.signal.runner import SignalRunner

RUNNERS = {"onnx": OnnxRunner, "fmu": FmuRunner, "mujoco": MujocoRunner, "signal": SignalRunner}


def test_the_capability_and_the_runner_contract_agree() -> None:
    assert set(RUNNERS) == set(COMPONENT_KINDS)
    for name, kind in COMPONENT_KINDS.items():
        declared = EVALUATED_AT_START in kind.capabilities
        assert declared == issubclass(RUNNERS[name], StartEvaluating), name
    assert EVALUATED_AT_START in COMPONENT_KINDS["onnx"].capabilities
