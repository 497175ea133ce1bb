"""Names of tensor elements (issue #34): one convention, the system file's.

results.csv named the element of a ``[1,1]`` tensor ``power[0]`` (flat) while checks and
connections write ``power[0,0]``. An element of a tensor is now named with one index per
dimension in results.csv, checks, plots and studies; a flat index written in the system file
selects the same column.
"""

from __future__ import annotations

import csv
from pathlib import Path

import onnx
from onnx import TensorProto, helper
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.results.csvfile import read_csv


def _affine(path: Path) -> Path:
    """``y = 2 * x + 1`` on a ``[1,2]`` tensor: f(0) = 1, never the value of a real input."""
    graph = helper.make_graph(
        [
            helper.make_node("Mul", ["x", "two"], ["twice"]),
            helper.make_node("Add", ["twice", "one"], ["y"]),
        ],
        "affine",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, [1, 2])],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, [1, 2])],
        [
            helper.make_tensor("two", TensorProto.DOUBLE, [], [2.0]),
            helper.make_tensor("one", TensorProto.DOUBLE, [], [1.0]),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model, full_check=True)
    onnx.save(model, path)
    return path


SYSTEM = """\
fmionnx: 1
name: start_values
run: {{stop: 4, step: 1}}
components:
  a: {{kind: signal, outputs: {{v: {{ramp: {{time: 0, initial: 3, final: 7, duration: 4}}}}}}}}
  b: {{kind: signal, outputs: {{v: {{constant: 10}}}}}}
  nn: {{kind: onnx, path: {model}, period: 2}}
connections:
  - a.v -> nn.x[0,0]
  - b.v -> nn.x[1]
plots:
  - {{y: ["nn.y[1]", "nn.y[0,0]"], file: y.png}}
checks:
  - name: two by index
    expect: final(nn.y[0,1]) == 21
  - name: flat index
    expect: final(nn.y[1]) == 21
"""


def system_file(tmp_path: Path) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(model=_affine(tmp_path / "affine.onnx")), encoding="utf-8")
    return path


def test_results_name_tensor_elements_by_one_index_per_dimension(tmp_path: Path) -> None:
    out = tmp_path / "out"
    done = CliRunner().invoke(app, ["run", str(system_file(tmp_path)), "--out", str(out), "-q"])
    assert done.exit_code == 0, done.output
    with (out / "results.csv").open(encoding="utf-8", newline="") as stream:
        header = next(csv.reader(stream))
    assert "nn.y[0,0]" in header
    assert "nn.y[0,1]" in header
    assert not {"nn.y[0]", "nn.y[1]"} & set(header)
    assert (out / "y.png").is_file()  # the plot found both columns, whichever spelling
    record = (out / "run.json").read_text(encoding="utf-8")
    assert '"passed": false' not in record  # both spellings of the check read the column
    assert read_csv(out / "results.csv")["nn.y[0,1]"][-1] == 21  # the quoted name reads back
