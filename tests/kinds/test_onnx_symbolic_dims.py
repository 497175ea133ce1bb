"""Symbolic ONNX dimensions, duplicate port names and missing external data (a bug hunt).

* an output with a symbolic dimension, recorded by default, crashed ``run`` (one column for
  three values);
* a dimension name fixed by an input was not carried to the outputs naming it: a system
  validated, then faulted;
* two unknown dimensions in one input validated and faulted ("6 elements cannot feed 3");
* an output named like an input (or two outputs of one name) gave duplicate ports;
* a missing external data file validated and faulted at run.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from tests.conftest import build_fixture_fmu, cli

Dims = Sequence[int | str]


def _identity(path: Path, x: Dims, y: Dims) -> Path:
    """A model ``y = Identity(x)`` with the shapes given (float32)."""
    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"])],
        "identity",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, list(x))],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, list(y))],
    )
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), path)
    return path


def _six(path: Path) -> Path:
    """A model of no inputs whose output ``y`` is six constant floats."""
    value = helper.make_tensor("c", TensorProto.FLOAT, [6], [1, 2, 3, 4, 5, 6])
    graph = helper.make_graph(
        [helper.make_node("Constant", [], ["y"], value=value)],
        "six",
        [],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [6])],
    )
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), path)
    return path


def _system(folder: Path, components: str, connections: Sequence[str]) -> Path:
    lines = ["fmionnx: 1", "name: dims", "run: {stop: 0.2, step: 0.1}", "components:"]
    lines += [f"  {line}" for line in components.strip().splitlines()]
    lines += ["connections:" if connections else "connections: []"]
    lines += [f"  - {c}" for c in connections]
    path = folder / "system.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _gain(folder: Path) -> str:
    fmu = build_fixture_fmu("Gain")
    return f"g: {{kind: fmu, path: {fmu}, parameters: {{v: [1, 2, 3], u: 4}}}}"


def _columns(out: Path) -> dict[str, list[float]]:
    with (out / "results.csv").open(encoding="utf-8") as file:
        rows = list(csv.DictReader(file))
    return {name: [float(row[name]) for row in rows] for name in rows[0]}


def test_a_symbolic_output_is_recorded_with_the_count_its_input_fixes(tmp_path: Path) -> None:
    _identity(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    components = f"{_gain(tmp_path)}\nd: {{kind: onnx, path: dyn.onnx}}"
    system = _system(tmp_path, components, ["g.w -> d.x"])
    code, output = cli("run", str(system), "--out", str(tmp_path / "out"))
    assert code == 0, output
    columns = _columns(tmp_path / "out")
    # each element of y under its own flat name, holding what g.w gave (k = 2)
    assert [columns[f"d.y[{i}]"][-1] for i in range(3)] == [2.0, 4.0, 6.0]


def test_a_name_an_input_fixes_sizes_the_outputs_naming_it(tmp_path: Path) -> None:
    _identity(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    _six(tmp_path / "six.onnx")
    components = "six: {kind: onnx, path: six.onnx}\nd: {kind: onnx, path: dyn.onnx}"
    system = _system(tmp_path, components, ["six.y -> d.x"])
    code, output = cli("run", str(system), "--out", str(tmp_path / "out"))
    assert code == 0, output
    columns = _columns(tmp_path / "out")
    assert [columns[f"d.y[{i}]"][-1] for i in range(6)] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]


def test_an_output_sized_by_an_input_that_cannot_fit_is_refused_at_compile(
    tmp_path: Path,
) -> None:
    _identity(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    _six(tmp_path / "six.onnx")
    vector = build_fixture_fmu("Vector3")
    components = (
        "six: {kind: onnx, path: six.onnx}\nd: {kind: onnx, path: dyn.onnx}\n"
        f"v: {{kind: fmu, path: {vector}}}"
    )
    system = _system(tmp_path, components, ["six.y -> d.x", "d.y -> v.u"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E032" in output
    assert "`d.y` carries 6 elements" in output
    assert "batch = 2" in output
    assert "`v.u` takes 3" in output


@pytest.mark.parametrize(
    ("x", "y", "unknown"),
    [(["a", "b", 3], ["a", "b", 3], "`a`, `b`"), (["?", "?", 3], [6], "`?`")],
)
def test_two_unknown_dimensions_in_one_input_are_ambiguous(
    tmp_path: Path, x: Dims, y: Dims, unknown: str
) -> None:
    _identity(tmp_path / "dyn.onnx", x, y)
    _six(tmp_path / "six.onnx")
    components = "six: {kind: onnx, path: six.onnx}\nd: {kind: onnx, path: dyn.onnx}"
    system = _system(tmp_path, components, ["six.y -> d.x"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E032" in output
    assert "ambiguous" in output
    assert unknown in output


def test_another_input_may_fix_a_dimension_of_an_ambiguous_one(tmp_path: Path) -> None:
    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"]), helper.make_node("Identity", ["z"], ["w"])],
        "two",
        [
            helper.make_tensor_value_info("x", TensorProto.FLOAT, ["a", "b", 3]),
            helper.make_tensor_value_info("z", TensorProto.FLOAT, ["a"]),
        ],
        [
            helper.make_tensor_value_info("y", TensorProto.FLOAT, ["a", "b", 3]),
            helper.make_tensor_value_info("w", TensorProto.FLOAT, ["a"]),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    onnx.save(model, tmp_path / "two.onnx")
    _six(tmp_path / "six.onnx")
    components = (
        f"{_gain(tmp_path)}\nsix: {{kind: onnx, path: six.onnx}}\nd: {{kind: onnx, path: two.onnx}}"
    )
    # z = w's three elements fixes a = 3: x's six elements then leave b no whole size
    system = _system(tmp_path, components, ["six.y -> d.x", "g.w -> d.z"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E032" in output
    assert "ambiguous" not in output
    # one element for z (a = 1) leaves b = 2: it runs
    system = _system(tmp_path, components, ["six.y -> d.x", "g.y -> d.z"])
    code, output = cli("run", str(system), "--out", str(tmp_path / "out"))
    assert code == 0, output
    columns = _columns(tmp_path / "out")
    assert [columns[f"d.y[{i}]"][-1] for i in range(6)] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]


def _pass_through(path: Path, outputs: Sequence[str]) -> Path:
    graph = helper.make_graph(
        [],
        "pass",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [3])],
        [helper.make_tensor_value_info(name, TensorProto.FLOAT, [3]) for name in outputs],
    )
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), path)
    return path


@pytest.mark.parametrize(
    ("outputs", "said"), [(["x"], "an input and an output"), (["y", "y"], "two outputs")]
)
def test_a_port_name_used_twice_is_refused_when_the_model_is_read(
    tmp_path: Path, outputs: Sequence[str], said: str
) -> None:
    if outputs != ["x"]:  # two outputs `y` of one Identity each
        graph = helper.make_graph(
            [helper.make_node("Identity", ["x"], ["y"])],
            "twice",
            [helper.make_tensor_value_info("x", TensorProto.FLOAT, [3])],
            [helper.make_tensor_value_info(n, TensorProto.FLOAT, [3]) for n in outputs],
        )
        model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
        onnx.save(model, tmp_path / "p.onnx")
    else:
        _pass_through(tmp_path / "p.onnx", outputs)
    code, output = cli("validate", str(tmp_path / "p.onnx"))
    assert code == 1, output
    assert "E013" in output
    assert said in output
    components = f"p: {{kind: onnx, path: p.onnx}}\n{_gain(tmp_path)}"
    system = _system(tmp_path, components, [f"p.{outputs[0]}[0] -> g.u"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E013" in output
    assert "E030" not in output


def test_a_missing_external_data_file_is_refused_at_compile(tmp_path: Path) -> None:
    weights = numpy_helper.from_array(np.ones(256, dtype=np.float32), "k")  # raw data
    graph = helper.make_graph(
        [helper.make_node("Mul", ["x", "k"], ["y"])],
        "scaled",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [256])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [256])],
        [weights],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    onnx.save_model(
        model, tmp_path / "m.onnx", save_as_external_data=True, location="w.bin", size_threshold=0
    )
    saved = onnx.load_model(tmp_path / "m.onnx", load_external_data=False)
    for entry in saved.graph.initializer[0].external_data:
        if entry.key == "location":
            entry.value = "missing.bin"
    onnx.save_model(saved, tmp_path / "m.onnx")
    (tmp_path / "w.bin").unlink()
    system = _system(tmp_path, "m: {kind: onnx, path: m.onnx}", [])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E010" in output
    assert "missing.bin" in output
    code, output = cli("validate", str(tmp_path / "m.onnx"))
    assert code == 1, output
    assert "E010" in output


def test_a_zero_dimension_beside_a_symbolic_one_divides_by_nothing() -> None:
    """`[batch, 0]`: the known part has no element, and `size % 0` raised ZeroDivisionError
    (a review). Nothing fed leaves `batch` as an undriven input's 1; elements fed are refused."""
    from fmionnx.core.dims import bind_dims, resolved_shape
    from fmionnx.core.types import Causality, DType, Port

    port = Port("x", Causality.INPUT, DType.FLOAT32, ("batch", 0))
    empty = bind_dims([port], {"x": 0})
    assert empty.problems == ()
    assert resolved_shape(port, empty, 0) == (1, 0)
    (problem,) = bind_dims([port], {"x": 3}).problems
    assert problem.message == "3 elements cannot fill [batch,0]: it is empty"
