"""Train and write ``feedforward.onnx``: a small MLP that learned the heating power a room needs.

Why a learned component in a heating loop: a PI controller alone reacts only once the room is
already too cold; a feed-forward that knows which power holds a temperature for a given outside
temperature acts at once. Here it is learned from steady-state measurements of the room (made
up below from its heat balance plus sensor noise, as a user would log them) rather than
derived, which is how such maps are usually obtained for real buildings.

The network: features ``[setpoint, outside temperature]`` (float32 ``[1,2]``, in degC) are
normalised, go through 8 tanh units and a linear output, ``power`` (float32 ``[1,1]``, W). The
hidden layer's weights are drawn once from a seeded generator and the output layer is fitted
by regularised least squares (an "extreme learning machine"): training is exact, takes
milliseconds and gives the same model on every run, so the build needs no training framework.
The file passes ``onnx.checker`` (full check) and strict shape inference.

Usage: ``python examples/from-scratch/feedforward.py [--out FILE]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 17
HIDDEN = 8
#: The room the measurements come from: its wall's thermal resistance (K/W).
ROOM_R = 0.01
DEFAULT_OUT = Path("build/examples/from-scratch/feedforward.onnx")


def measurements(seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Steady states of the room: (setpoint, outside) pairs and the power that held them."""
    rng = np.random.default_rng(seed)
    setpoint = rng.uniform(15.0, 25.0, 400)
    outside = rng.uniform(-10.0, 15.0, 400)
    power = (setpoint - outside) / ROOM_R + rng.normal(0.0, 20.0, 400)  # noisy power meter
    return np.column_stack([setpoint, outside]), power


def train(features: np.ndarray, power: np.ndarray, seed: int = 2) -> dict[str, np.ndarray]:
    """Fixed random hidden layer, least-squares output layer; returns the network's tensors."""
    rng = np.random.default_rng(seed)
    mean = features.mean(axis=0)
    scale = features.std(axis=0)
    w1 = rng.normal(0.0, 0.5, (2, HIDDEN))
    b1 = rng.normal(0.0, 0.5, HIDDEN)
    hidden = np.tanh(((features - mean) / scale) @ w1 + b1)
    design = np.column_stack([hidden, np.ones(len(hidden))])
    ridge = 1e-6 * np.eye(HIDDEN + 1)
    solution = np.linalg.solve(design.T @ design + ridge, design.T @ power)
    return {
        "mean": mean.reshape(1, 2),
        "scale": scale.reshape(1, 2),
        "w1": w1,
        "b1": b1,
        "w2": solution[:HIDDEN].reshape(HIDDEN, 1),
        "b2": solution[HIDDEN:],
    }


def predict(weights: dict[str, np.ndarray], features: np.ndarray) -> np.ndarray:
    """What the ONNX graph computes, in numpy (used to report the fit)."""
    hidden = np.tanh(
        ((features - weights["mean"]) / weights["scale"]) @ weights["w1"] + weights["b1"]
    )
    result: np.ndarray = hidden @ weights["w2"] + weights["b2"]
    return result.ravel()


def build_model(weights: dict[str, np.ndarray]) -> onnx.ModelProto:
    """The graph: Sub, Div (normalisation), Gemm, Tanh, Gemm; float32 weights as initializers."""
    initializers = [
        numpy_helper.from_array(value.astype(np.float32), name) for name, value in weights.items()
    ]
    nodes = [
        helper.make_node("Sub", ["features", "mean"], ["centred"]),
        helper.make_node("Div", ["centred", "scale"], ["normalised"]),
        helper.make_node("Gemm", ["normalised", "w1", "b1"], ["pre"]),
        helper.make_node("Tanh", ["pre"], ["hidden"]),
        helper.make_node("Gemm", ["hidden", "w2", "b2"], ["power"]),
    ]
    features = helper.make_tensor_value_info("features", TensorProto.FLOAT, [1, 2])
    features.doc_string = "[setpoint, outside temperature] in degC"
    power = helper.make_tensor_value_info("power", TensorProto.FLOAT, [1, 1])
    power.doc_string = "heating power that holds the setpoint, W"
    graph = helper.make_graph(nodes, "heating_feedforward", [features], [power], initializers)
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", OPSET)],
        producer_name="fmionnx examples/from-scratch/feedforward.py",
        producer_version="1.0",
    )
    model.ir_version = 8  # readable by onnxruntime releases of the last years
    model.doc_string = "Learned heating feed-forward: steady-state power from setpoint and outside."
    onnx.checker.check_model(model, full_check=True)
    return onnx.shape_inference.infer_shapes(model, check_type=True, strict_mode=True)


def write_model(path: Path) -> float:
    """Train, write the model to ``path``; return the largest fit error on the data (W)."""
    features, power = measurements()
    weights = train(features, power)
    error = float(np.max(np.abs(predict(weights, features) - power)))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(build_model(weights).SerializeToString())
    return error


def main(argv: list[str] | None = None) -> int:
    """Command line: ``feedforward.py [--out FILE]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    error = write_model(args.out)
    print(f"{args.out}: trained, largest error on the measurements {error:.0f} W")
    return 0


if __name__ == "__main__":
    sys.exit(main())
