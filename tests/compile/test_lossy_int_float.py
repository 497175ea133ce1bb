"""Integer -> float connections that round (a bug hunt).

docs/types.md called every integer -> float64 conversion one "that cannot lose a value", and
the compiler warned about none of them: ``Types3.y_i64`` connected to an ONNX ``float64``
input carried 10**18 + 1 as 1e18 without a word, and into ``float32`` worse. An integer
converts exactly only when the float's significand (53 bits for float64, 24 for float32)
holds every magnitude bit of the integer type; otherwise the connection is W031.

The expectation is computed here from numpy's own conversion of each integer type's largest
value, not from the compiler's bit table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper

import fmionnx
from fmionnx.core.diagnostics import Diagnostic
from tests.conftest import build_fixture_fmu

#: Types3's integer outputs and their types.
INTEGER_OUTPUTS = {
    "y_i8": np.int8,
    "y_u8": np.uint8,
    "y_i16": np.int16,
    "y_u16": np.uint16,
    "y_i32": np.int32,
    "y_u32": np.uint32,
    "y_i64": np.int64,
    "y_u64": np.uint64,
}
FLOATS = {"f64": (TensorProto.DOUBLE, np.float64), "f32": (TensorProto.FLOAT, np.float32)}


def _identity_model(path: Path, elem_type: int) -> Path:
    """One input and one output per integer output of Types3, all of ``elem_type``."""
    names = list(INTEGER_OUTPUTS)
    graph = helper.make_graph(
        [helper.make_node("Identity", [f"x_{n}"], [f"out_{n}"]) for n in names],
        "identity",
        [helper.make_tensor_value_info(f"x_{n}", elem_type, []) for n in names],
        [helper.make_tensor_value_info(f"out_{n}", elem_type, []) for n in names],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


@pytest.fixture(scope="module")
def warnings(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[str, str], Diagnostic]:
    """W031 of a system connecting every integer output to a float64 and a float32 input."""
    folder = tmp_path_factory.mktemp("lossy")
    lines = [
        "fmionnx: 1",
        "name: lossy",
        "run: {stop: 0.2, step: 0.1}",
        "components:",
        f"  src: {{kind: fmu, path: {build_fixture_fmu('Types3')}}}",
    ]
    for name, (elem_type, _) in FLOATS.items():
        model = _identity_model(folder / f"{name}.onnx", elem_type)
        lines.append(f"  {name}: {{kind: onnx, path: {model}}}")
    lines.append("connections:")
    lines += [f"  - src.{p} -> {f}.x_{p}" for f in FLOATS for p in INTEGER_OUTPUTS]
    path = folder / "system.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    system = fmionnx.load(path)
    found: dict[tuple[str, str], Diagnostic] = {}
    for diagnostic in system.diagnostics:
        if diagnostic.code == "W031":
            source, target = diagnostic.message.split("`")[1::2][:2]
            found[source.removeprefix("src."), target.split(".")[0]] = diagnostic
    return found


def _rounds(integer: type[np.integer], floating: type[np.floating]) -> bool:
    """Whether numpy's conversion changes some value of ``integer`` (its extremes suffice)."""
    info = np.iinfo(integer)
    return any(int(floating(value)) != value for value in (int(info.min), int(info.max)))


@pytest.mark.parametrize("target", list(FLOATS))
@pytest.mark.parametrize("port", list(INTEGER_OUTPUTS))
def test_an_integer_into_a_float_warns_exactly_when_it_rounds(
    warnings: dict[tuple[str, str], Diagnostic], port: str, target: str
) -> None:
    expected = _rounds(INTEGER_OUTPUTS[port], FLOATS[target][1])
    assert ((port, target) in warnings) == expected


def test_the_examples_of_the_hunt_warn_and_say_what_rounds(
    warnings: dict[tuple[str, str], Diagnostic],
) -> None:
    to_double = warnings["y_i64", "f64"]
    assert (
        to_double.message
        == "`src.y_i64` (int64) -> `f64.x_y_i64` (float64) may lose precision or range"
    )
    assert to_double.hint is not None
    assert "2^53 (9007199254740992)" in to_double.hint
    assert "float64" in to_double.hint
    assert "2^24 (16777216)" in (warnings["y_i32", "f32"].hint or "")
    # the widest exact ones stay silent: int32 -> float64 and int16 -> float32
    assert ("y_i32", "f64") not in warnings
    assert ("y_u16", "f32") not in warnings
