"""Chains of symbolic ONNX components: a connection whose two ends both have symbolic
shapes was refused (E032 "both … have symbolic shapes") even when the source's count is
fixed by what its own inputs are fed. It is now sized in dataflow order, as the runner sizes
its tensors; what nothing fixes (a loop of symbolic components, an output dimension no input
names) is still refused."""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

import onnx
from onnx import TensorProto, helper

from tests.conftest import cli

Dims = Sequence[int | str]


def _save(path: Path, graph: onnx.GraphProto) -> None:
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), path)


def _doubler(path: Path, x: Dims, y: Dims) -> None:
    """``y = x + x`` (float32) with the shapes given: each link of a chain changes the values,
    so a value read at the end went through every one."""
    _save(
        path,
        helper.make_graph(
            [helper.make_node("Add", ["x", "x"], ["y"])],
            "doubler",
            [helper.make_tensor_value_info("x", TensorProto.FLOAT, list(x))],
            [helper.make_tensor_value_info("y", TensorProto.FLOAT, list(y))],
        ),
    )


def _six(path: Path) -> None:
    """No inputs; ``y`` is the six floats 1..6."""
    value = helper.make_tensor("c", TensorProto.FLOAT, [6], [1, 2, 3, 4, 5, 6])
    _save(
        path,
        helper.make_graph(
            [helper.make_node("Constant", [], ["y"], value=value)],
            "six",
            [],
            [helper.make_tensor_value_info("y", TensorProto.FLOAT, [6])],
        ),
    )


def _system(folder: Path, components: Sequence[str], connections: Sequence[str]) -> Path:
    lines = ["fmionnx: 1", "name: chain", "run: {stop: 0.2, step: 0.1}", "components:"]
    lines += [f"  {line}" for line in components]
    lines += ["connections:", *(f"  - {c}" for c in connections)]
    path = folder / "system.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _last_row(out: Path) -> dict[str, float]:
    with (out / "results.csv").open(encoding="utf-8") as file:
        rows = list(csv.DictReader(file))
    return {name: float(value) for name, value in rows[-1].items()}


def test_a_chain_of_symbolic_components_is_sized_from_its_fixed_source(tmp_path: Path) -> None:
    _six(tmp_path / "six.onnx")
    _doubler(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    components = [
        "six: {kind: onnx, path: six.onnx}",
        "d1: {kind: onnx, path: dyn.onnx}",
        "d2: {kind: onnx, path: dyn.onnx}",
    ]
    system = _system(tmp_path, components, ["six.y -> d1.x", "d1.y -> d2.x"])
    code, output = cli("run", str(system), "--out", str(tmp_path / "out"))
    assert code == 0, output
    row = _last_row(tmp_path / "out")
    assert [row[f"d1.y[{i}]"] for i in range(6)] == [2.0, 4.0, 6.0, 8.0, 10.0, 12.0]
    assert [row[f"d2.y[{i}]"] for i in range(6)] == [4.0, 8.0, 12.0, 16.0, 20.0, 24.0]
    assert "d2.y[6]" not in row


def test_a_chain_listed_against_its_dataflow_is_sized_too(tmp_path: Path) -> None:
    """Components and connections written downstream first: the sizes still flow from the
    fixed source, through a model whose shapes differ (``[n]`` into ``[batch, 2]``)."""
    _six(tmp_path / "six.onnx")
    _doubler(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    _doubler(tmp_path / "flat.onnx", ["n"], ["n"])
    _doubler(tmp_path / "pairs.onnx", ["batch", 2], ["batch", 2])
    components = [
        "d3: {kind: onnx, path: pairs.onnx}",
        "d2: {kind: onnx, path: flat.onnx}",
        "d1: {kind: onnx, path: dyn.onnx}",
        "six: {kind: onnx, path: six.onnx}",
    ]
    connections = ["d2.y -> d3.x", "d1.y -> d2.x", "six.y -> d1.x"]
    system = _system(tmp_path, components, connections)
    code, output = cli("run", str(system), "--out", str(tmp_path / "out"))
    assert code == 0, output
    row = _last_row(tmp_path / "out")
    assert [row[f"d3.y[{i}]"] for i in range(6)] == [8.0, 16.0, 24.0, 32.0, 40.0, 48.0]


def test_a_count_the_chain_fixes_is_checked_at_the_next_model(tmp_path: Path) -> None:
    """Six elements reach a ``[batch, 4]`` input through a symbolic link: refused at compile."""
    _six(tmp_path / "six.onnx")
    _doubler(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    _doubler(tmp_path / "fours.onnx", ["batch", 4], ["batch", 4])
    components = [
        "six: {kind: onnx, path: six.onnx}",
        "d1: {kind: onnx, path: dyn.onnx}",
        "d2: {kind: onnx, path: fours.onnx}",
    ]
    system = _system(tmp_path, components, ["six.y -> d1.x", "d1.y -> d2.x"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E032" in output
    assert "6 elements cannot fill [batch,4]" in output


def test_a_loop_of_symbolic_components_is_still_refused(tmp_path: Path) -> None:
    _doubler(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    components = ["d1: {kind: onnx, path: dyn.onnx}", "d2: {kind: onnx, path: dyn.onnx}"]
    system = _system(tmp_path, components, ["d1.y -> d2.x", "d2.y -> d1.x"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E032" in output
    assert "both `d1.y` and `d2.x` have symbolic shapes" in output
    assert "both `d2.y` and `d1.x` have symbolic shapes" in output
    assert "Traceback" not in output


def test_an_output_dimension_no_input_names_is_still_refused(tmp_path: Path) -> None:
    _six(tmp_path / "six.onnx")
    _doubler(tmp_path / "dyn.onnx", ["batch", 3], ["batch", 3])
    _doubler(tmp_path / "free.onnx", ["batch", 3], ["other", 3])
    components = [
        "six: {kind: onnx, path: six.onnx}",
        "f: {kind: onnx, path: free.onnx}",
        "d: {kind: onnx, path: dyn.onnx}",
    ]
    system = _system(tmp_path, components, ["six.y -> f.x", "f.y -> d.x"])
    code, output = cli("validate", str(system))
    assert code == 1, output
    assert "E032" in output
    assert "both `f.y` and `d.x` have symbolic shapes" in output
    assert "`other`" in output
