"""The Python API, a lone ONNX model and ``fmionnx sweep``'s counts (a fifth bug hunt).

* ``fmionnx run model.onnx --param k=5`` (and ``fmionnx.run(..., params=...)``) dropped the
  value without a word, an unknown name too; an ONNX component's parameters are its inputs'
  values, as a system file's ``parameters:`` sets them, so ``--param`` now sets them;
  ``--stop-time`` was dropped the same way and is refused;
* ``fmionnx.run(fmionnx.load("m.onnx"))`` without ``inputs`` ran the model over time and
  wrote ``out/<name>/`` where ``fmionnx.run("m.onnx")`` infers it once;
* ``fmionnx sweep --workers 0`` got Typer's range box instead of the project's ``error:``;
* ``params=`` was typed ``Scalar``: numpy values, taken at run time, failed ``mypy --strict``
  (the values below are numpy's on purpose, for a type checker reading this file).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx.pipeline.errors import RequestError
from fmionnx.pipeline.infer import InferenceOutcome
from tests.conftest import cli


@pytest.fixture
def scaling(tmp_path: Path) -> tuple[Path, Path]:
    """``y = x * k`` (``x`` two floats, ``k`` one), and an input file ``x = [3, 4]``."""
    import onnx
    from onnx import TensorProto, helper

    graph = helper.make_graph(
        [helper.make_node("Mul", ["x", "k"], ["y"])], "mk",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [2]),
         helper.make_tensor_value_info("k", TensorProto.FLOAT, [1])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [2])],
    )  # fmt: skip
    model = tmp_path / "mk.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), model)
    data = tmp_path / "x.npy"
    np.save(data, np.array([3, 4], dtype=np.float32))
    return model, data


# -- --param on a lone ONNX model: an input's value, as in a system file ---------------------


def test_a_param_sets_an_onnx_input_for_the_inference(
    scaling: tuple[Path, Path], tmp_path: Path
) -> None:
    model, data = scaling
    out = tmp_path / "cli"
    code, output = cli(
        "run", str(model), "--input", f"x={data}", "--param", "k=5", "--out", str(out)
    )
    assert code == 0, output
    np.testing.assert_array_equal(np.load(out / "y.npy"), np.array([15, 20], np.float32))
    # Both inputs by --param (the second by `component.port`), no .npy file at all.
    code, output = cli("run", str(model), "-p", "x=[1, 2]", "-p", "mk.k=2", "--no-out")
    assert code == 0, output
    assert "[2., 4.]" in output


def test_a_param_sets_an_onnx_input_from_python(scaling: tuple[Path, Path]) -> None:
    model, data = scaling
    outcome = fmionnx.run(model, inputs={"x": data}, params={"k": np.float32(5)}, no_out=True)
    assert isinstance(outcome, InferenceOutcome)
    np.testing.assert_array_equal(outcome.outputs["y"], np.array([15, 20], np.float32))
    assert list(outcome["mk.y[1]"]) == [20.0]


@pytest.mark.parametrize(
    ("flags", "said"),
    [
        (("-p", "zz=5"), "error: --param `zz`: `mk` has no parameter `zz`; expected one of `k`, `x`"),
        (("-p", "kk=5"), "error: --param `kk`: `mk` has no parameter `kk`; did you mean `k`?"),
        (("-p", "k=[1, 2]"), "error: --param `k`: expected 1 value(s) of type float32 (shape [1])"),
        (("-p", "x=[1, 2]"), "error: --param and --input both give the input `x`: give it one value"),
        (("--stop-time", "3"), "error: --stop-time applies to systems and FMUs, not to a single ONNX"),
    ],
)  # fmt: skip
def test_what_an_inference_cannot_take_is_refused_naming_it(
    scaling: tuple[Path, Path], tmp_path: Path, flags: tuple[str, ...], said: str
) -> None:
    model, data = scaling
    out = tmp_path / "refused"
    code, output = cli("run", str(model), "--input", f"x={data}", *flags, "--out", str(out))
    assert (code, output[: len(said)]) == (2, said)
    assert not out.exists()


def test_a_refused_param_is_a_request_error_from_python(scaling: tuple[Path, Path]) -> None:
    model, data = scaling
    with pytest.raises(RequestError, match="has no parameter `zz`"):
        fmionnx.run(model, inputs={"x": data}, params={"zz": 1}, no_out=True)
    with pytest.raises(RequestError, match="--stop-time applies to systems and FMUs"):
        fmionnx.run(model, stop_time=2.0, no_out=True)


# -- a loaded lone ONNX model: inferred once, as by its path ---------------------------------


def test_a_loaded_onnx_model_is_inferred_once_as_by_its_path(
    scaling: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, _ = scaling
    monkeypatch.chdir(tmp_path)
    by_path = fmionnx.run(model)
    loaded = fmionnx.run(fmionnx.load(model))
    assert isinstance(loaded, InferenceOutcome)
    assert isinstance(by_path, InferenceOutcome)
    assert (loaded.out, loaded.files) == (None, ()) == (by_path.out, by_path.files)
    assert not (tmp_path / "out").exists()  # a run over time wrote out/mk/results.csv here
    assert list(loaded["time"]) == [0.0] == list(by_path["time"])
    assert loaded.outputs.keys() == by_path.outputs.keys() == {"y"}
    np.testing.assert_array_equal(loaded.outputs["y"], by_path.outputs["y"])


def test_a_loaded_onnx_model_takes_params_and_runs_once(
    scaling: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model, _ = scaling
    monkeypatch.chdir(tmp_path)  # a run over time (the bug) writes out/mk/ here
    system = fmionnx.load(model)
    outcome = fmionnx.run(system, params={"x": (1.0, 2.0), "k": 3.0})
    assert isinstance(outcome, InferenceOutcome)
    np.testing.assert_array_equal(outcome.outputs["y"], np.array([3, 6], np.float32))
    # numpy values, typed as accepted; System.run: the same one inference
    result = system.with_overrides(params={"x": np.array([1.0, 2.0]), "k": np.int64(3)}).run()
    assert list(result["time"]) == [0.0]
    assert (list(result["mk.y[0]"]), list(result["mk.y[1]"])) == ([3.0], [6.0])


# -- sweep counts: the project's usage error, not Typer's box --------------------------------


@pytest.mark.parametrize(
    ("flags", "said"),
    [
        (("--workers", "0"), "--workers takes a whole number of local worker processes, at least 1, not `0`"),
        (("-w", "-2"), "--workers takes a whole number of local worker processes, at least 1, not `-2`"),
        (("--batch", "0"), "--batch takes a whole number of cases per Dask task, at least 1, not `0`"),
        (("--batch", "-1"), "--batch takes a whole number of cases per Dask task, at least 1, not `-1`"),
    ],
)  # fmt: skip
def test_a_sweep_count_below_one_is_a_usage_error_in_our_words(
    tmp_path: Path, flags: tuple[str, ...], said: str
) -> None:
    study, out = tmp_path / "study.yaml", tmp_path / "study-out"
    study.write_text("fmionnx: 1\n", encoding="utf-8")  # never read: the options come first
    code, output = cli("sweep", str(study), "--out", str(out), *flags)
    assert (code, output) == (2, f"error: {said}")
    assert not out.exists()


def test_an_array_for_a_symbolic_input_is_refused_pointing_at_input(tmp_path: Path) -> None:
    """`-p x=[1,2,3]` on `x: [batch, 3]` said only "expected 1 value(s)" (a review): a port
    whose size is known once fed takes one value here; the message says where arrays go."""
    import onnx
    from onnx import TensorProto, helper

    graph = helper.make_graph(
        [helper.make_node("Identity", ["x"], ["y"])], "dyn",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["batch", 3])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["batch", 3])],
    )  # fmt: skip
    model = tmp_path / "dyn.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), model)
    code, output = cli("run", str(model), "-p", "x=[1,2,3]")
    assert code == 2, output
    assert "expected 1 value(s) of type float32 (shape [batch,3])" in output
    assert "takes one value here" in output
    assert "--input NAME=file.npy" in output
    outcome = fmionnx.run(model, params={"x": 1.5})
    assert isinstance(outcome, InferenceOutcome)
    assert outcome.outputs["y"].tolist() == [[1.5, 1.5, 1.5]]
