"""ONNX and MuJoCo runners inside systems: faults, lazy cameras, single-model ONNX runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper

import fmionnx
from fmionnx.api import run_onnx_once
from fmionnx.core.errors import RunError
from fmionnx.runtime.result import RunOptions, RunStatus


def _gather_model(path: Path) -> Path:
    """y = table[idx] with a 3-entry table: an index >= 3 is an onnxruntime run-time error."""
    table = helper.make_tensor("table", TensorProto.FLOAT, [3], [10.0, 20.0, 30.0])
    graph = helper.make_graph(
        [helper.make_node("Gather", ["table", "idx"], ["y"], axis=0)],
        "gather",
        [helper.make_tensor_value_info("idx", TensorProto.INT64, [1])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1])],
        [table],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


def _mean_model(path: Path) -> Path:
    """m = mean of an RGB image [1,H,W,3] as float."""
    graph = helper.make_graph(
        [
            helper.make_node("Cast", ["image"], ["f"], to=TensorProto.FLOAT),
            helper.make_node("ReduceMean", ["f"], ["m"], keepdims=0),
        ],
        "mean",
        [helper.make_tensor_value_info("image", TensorProto.UINT8, [1, 24, 32, 3])],
        [helper.make_tensor_value_info("m", TensorProto.FLOAT, [])],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


def test_onnx_runtime_error_stops_the_run_naming_the_component(
    fixture_fmu, write_system, tmp_path: Path
) -> None:
    model = _gather_model(tmp_path / "gather.onnx")
    path = write_system(
        f"""
fmionnx: 1
name: onnx_fault
run: {{stop: 1.0, step: 0.1}}
components:
  counter: {{kind: fmu, path: {fixture_fmu("Vector3")}}}
  lookup: {{kind: onnx, path: {model}}}
connections:
  - counter.count -> lookup.idx
"""
    )
    result = fmionnx.load(path).run(isolate="none")
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "lookup"
    with pytest.raises(RunError, match=r"component `lookup` at t=0\.\d+ s: onnxruntime failed"):
        raise result.error
    assert result["counter.count"][-1] >= 2


def test_onnx_model_runs_once_on_given_inputs(tmp_path: Path) -> None:
    system = fmionnx.load(_gather_model(tmp_path / "gather.onnx"))
    outputs = run_onnx_once(system, {"idx": np.array([2])})
    assert outputs["y"].tolist() == [30.0]


SCENE = """
<mujoco>
  <option timestep="0.01"/>
  <visual><global offwidth="64" offheight="48"/></visual>
  <worldbody>
    <light pos="0 0 3"/>
    <geom type="plane" size="2 2 .1" rgba=".4 .4 .4 1"/>
    <body name="cart" pos="0 0 .1">
      <joint name="slide" type="slide" axis="1 0 0" {joint}/>
      <geom type="box" size=".1 .1 .1" rgba="1 0 0 1" mass="{mass}"/>
    </body>
    <camera name="eye" pos="0 -1 .3" xyaxes="1 0 0 0 .3 1"/>
  </worldbody>
  <actuator><motor name="push" joint="slide" gear="{gear}"/></actuator>
  <sensor><jointpos name="x" joint="slide"/></sensor>
</mujoco>
"""


def _scene(tmp_path: Path, *, joint: str = "", mass: float = 1.0, gear: float = 1.0) -> Path:
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.format(joint=joint, mass=mass, gear=gear))
    return path


class _Frames:
    def __init__(self) -> None:
        self.times: list[float] = []

    def frame(self, component: str, port: str, time: float, image: np.ndarray) -> None:
        assert image.shape == (24, 32, 3)
        self.times.append(round(time, 9))


def test_camera_is_rendered_only_when_its_consumer_is_due(write_system, tmp_path: Path) -> None:
    scene = _scene(tmp_path)
    model = _mean_model(tmp_path / "mean.onnx")
    path = write_system(
        f"""
fmionnx: 1
name: camera
run: {{stop: 1.0, step: 0.01}}
components:
  world: {{kind: mujoco, path: {scene}, cameras: {{eye: {{width: 32, height: 24}}}}}}
  brightness: {{kind: onnx, path: {model}, period: 0.25}}
connections:
  - world.eye -> brightness.image
record: [brightness.m, world.x]
"""
    )
    frames = _Frames()
    result = fmionnx.load(path).run(options=RunOptions(frames=frames))
    assert result.status is RunStatus.COMPLETED
    # the first frame is the initial scene, for the model's outputs at the start time
    # (docs/execution.md, "Initial values"); then one per step of the model
    assert frames.times == [0.0, 0.0, 0.25, 0.5, 0.75]
    assert 0 < result["brightness.m"][-1] < 255


def test_mujoco_instability_stops_the_run(fixture_fmu, write_system, tmp_path: Path) -> None:
    scene = _scene(tmp_path, joint='stiffness="1e12"', mass=1e-6, gear=1e9)
    path = write_system(
        f"""
fmionnx: 1
name: unstable
run: {{stop: 1.0, step: 0.01}}
components:
  world: {{kind: mujoco, path: {scene}}}
  source: {{kind: fmu, path: {fixture_fmu("Gain")}, parameters: {{u: 1.0}}}}
connections:
  - source.y -> world.push
  - world.x -> source.v[0]
"""
    )
    result = fmionnx.load(path).run(isolate="none")
    assert result.status is RunStatus.FAULT
    assert result.error is not None
    assert result.error.component == "world"
    with pytest.raises(RunError, match=r"component `world` at t=.* the physics became unstable"):
        raise result.error
    assert result.steps_done < 100
