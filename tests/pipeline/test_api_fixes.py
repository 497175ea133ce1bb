"""The Python API does what ``fmionnx run`` and ``fmionnx sweep`` do (bug hunts).

* ``fmionnx.run("model.onnx", inputs=...)`` ran the model as a two-step system from its
  start values, its inputs ignored, where the CLI infers it once;
* ``System.run(signals=("g.y",))`` raised AttributeError, an unknown port KeyError, and
  ``fmionnx.run(signals=...)`` was refused naming a flag that does not exist;
* a run that raised (a progress callback's exception) left its Rerun recording half-written
  and its Foxglove server listening: the next run on the port was refused;
* numpy numbers, numpy arrays and tuples were refused as ``--param`` values and times;
* ``fmionnx.sweep(workers=0)`` ran without a word where the CLI refuses it;
* a ``--rrd`` inside ``--out`` was not in the folder's ownership record.
"""

from __future__ import annotations

import re
import socket
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.core.owned import OwnedFolder
from fmionnx.core.types import PortRef
from fmionnx.pipeline.errors import RequestError

SYSTEM = """\
fmionnx: 1
name: gained
run: {{stop: 0.5, step: 0.01}}
components:
  src:
    kind: signal
    outputs:
      u: {{sine: {{amplitude: 1, frequency: 1}}, unit: m}}
  g: {{kind: fmu, path: {gain}, parameters: {{k: 3}}}}
connections:
  - src.u -> g.u
"""


@pytest.fixture
def system_file(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(gain=fixture_fmu("Gain")), encoding="utf-8")
    return path


# -- an ONNX model from Python: one inference, as the CLI -----------------------------------


@pytest.fixture
def squaring(tmp_path: Path) -> tuple[Path, Path]:
    """``y = x * x`` on two floats, and an input file ``x = [3, 4]``."""
    import onnx
    from onnx import TensorProto, helper

    graph = helper.make_graph(
        [helper.make_node("Mul", ["x", "x"], ["y"])], "sq",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [2])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, [2])],
    )  # fmt: skip
    model = tmp_path / "sq.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)]), model)
    data = tmp_path / "x.npy"
    np.save(data, np.array([3, 4], dtype=np.float32))
    return model, data


def test_an_onnx_model_run_from_python_is_inferred_once_as_the_cli_does(
    squaring: tuple[Path, Path], tmp_path: Path
) -> None:
    model, data = squaring
    api, cli = tmp_path / "api", tmp_path / "cli"
    outcome = fmionnx.run(model, inputs={"x": data}, out=api)
    assert outcome.exit_status == 0
    assert outcome.files == (api / "y.npy",)
    np.testing.assert_array_equal(outcome.outputs["y"], np.array([9, 16], np.float32))  # type: ignore[attr-defined]
    assert list(outcome["sq.y[1]"]) == [16.0]  # one row, named as a run names its columns
    done = CliRunner().invoke(app, ["run", str(model), "--input", f"x={data}", "--out", str(cli)])
    assert done.exit_code == 0, done.output
    assert sorted(p.name for p in api.iterdir()) == sorted(p.name for p in cli.iterdir())
    assert (api / "y.npy").read_bytes() == (cli / "y.npy").read_bytes()


def test_an_inference_records_no_signals_over_time(squaring: tuple[Path, Path]) -> None:
    model, data = squaring
    with pytest.raises(RequestError, match="not a single ONNX inference"):
        fmionnx.run(model, inputs={"x": data}, signals=("sq.y",))
    with pytest.raises(RequestError, match="--record records a run over time"):
        fmionnx.run(model, inputs={"x": data}, record=model.parent / "r.mcap")


# -- signals by name ------------------------------------------------------------------------


def test_signals_are_named_as_strings_or_port_refs(system_file: Path) -> None:
    system = fmionnx.load(system_file)
    assert list(system.run(signals=("g.y",), isolate="none").signals) == ["g.y"]
    assert list(system.run(signals="g.y", isolate="none").signals) == ["g.y"]
    assert list(system.run(signals=[PortRef("g", "u")], isolate="none").signals) == ["g.u"]
    outcome = fmionnx.run(system_file, no_out=True, isolate="none", signals=["src.u"])
    assert list(outcome.result.signals) == ["src.u"]


@pytest.mark.parametrize(
    ("signal", "said"),
    [
        (PortRef("g", "nope"), "signals: `g.nope`: component `g` (fmu) has no port `nope`"),
        ("zz.y", "signals: `zz.y`: unknown component `zz`"),
        ("g.yy", "did you mean `y`?"),
    ],
)
def test_an_unknown_signal_is_refused_naming_it(
    system_file: Path, signal: str | PortRef, said: str
) -> None:
    with pytest.raises(RequestError, match=re.escape(said)):
        fmionnx.load(system_file).run(signals=(signal,), isolate="none")
    with pytest.raises(RequestError, match=re.escape(said)):
        fmionnx.run(system_file, no_out=True, signals=(signal,))


# -- live views let go when the run raises ---------------------------------------------------


def _raising(done: int, total: int, time: float) -> None:
    raise ValueError("a callback of the caller's")


def test_a_run_that_raises_leaves_no_half_written_recording(
    system_file: Path, tmp_path: Path
) -> None:
    pytest.importorskip("rerun")
    folder = tmp_path / "recordings"
    with pytest.raises(ValueError, match="a callback of the caller's"):
        fmionnx.load(system_file).run(progress=_raising, rrd=folder / "run.rrd", isolate="none")
    assert list(folder.iterdir()) == []  # neither the hidden .part nor a run.rrd


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_a_run_that_raises_frees_its_foxglove_port_for_the_next_run(system_file: Path) -> None:
    pytest.importorskip("foxglove")
    system = fmionnx.load(system_file)
    view = f"foxglove:{_free_port()}"
    with pytest.raises(ValueError, match="a callback of the caller's"):
        system.run(progress=_raising, view=view, isolate="none")
    assert system.run(view=view, isolate="none").status.value == "completed"


# -- numpy values ---------------------------------------------------------------------------


def test_numpy_numbers_arrays_and_tuples_are_values(system_file: Path) -> None:
    gains = np.arange(1, 4)  # np.int64 elements
    outcome = fmionnx.run(
        system_file, no_out=True, isolate="none", stop_time=gains[0],
        params={"g.k": gains[1], "g.v": np.array([1.0, 2.0, 3.0])},
    )  # fmt: skip
    assert outcome.result.stop == 1.0
    (gain,) = [c for c in outcome.system.compiled.components if c.name == "g"]
    assert {p.port: p.value for p in gain.parameters} == {"k": (2.0,), "v": (1.0, 2.0, 3.0)}
    system = fmionnx.load(system_file).with_overrides(
        stop_time=np.float32(0.25), params={"g.v": (1.0, np.float64(2.0), 3)}
    )
    assert system.compiled.run.stop == 0.25
    assert type(system.compiled.run.stop) is float


def test_a_numpy_bool_stays_a_truth_value_not_a_number(system_file: Path) -> None:
    with pytest.raises(RequestError, match=r"--param `g.k`: expected 1 value\(s\) of type"):
        fmionnx.run(system_file, no_out=True, params={"g.k": np.bool_(True)})
    with pytest.raises(RequestError, match="--stop-time takes a number, not `True`"):
        fmionnx.run(system_file, no_out=True, stop_time=np.bool_(True))


# -- a study's counts -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("option", "value", "said"),
    [
        ("workers", 0, "--workers takes a whole number of local worker processes, at least 1"),
        ("workers", -1, "--workers takes a whole number"),
        ("batch", 0, "--batch takes a whole number of cases per Dask task, at least 1"),
        ("batch", 1.5, "--batch takes a whole number"),
    ],
)
def test_a_study_refuses_counts_below_one_as_the_cli_does(
    system_file: Path, tmp_path: Path, option: str, value: object, said: str
) -> None:
    study = tmp_path / "study.yaml"
    study.write_text(
        f"fmionnx: 1\nsystem: {system_file.name}\nparameters:\n  g.k: [1, 2]\n"
        "metrics:\n  peak: max(g.y)\n",
        encoding="utf-8",
    )
    out = tmp_path / "study"
    with pytest.raises(RequestError, match=said):
        fmionnx.sweep(study, out, **{option: value})  # type: ignore[arg-type]
    assert not out.exists()


# -- --rrd inside --out ---------------------------------------------------------------------


def test_a_recording_inside_the_results_folder_is_the_runs_own(
    system_file: Path, tmp_path: Path
) -> None:
    pytest.importorskip("rerun")
    out = tmp_path / "out"
    outcome = fmionnx.run(system_file, out=out, rrd=out / "run.rrd", isolate="none")
    assert out / "run.rrd" in outcome.files
    assert OwnedFolder(out).proven("run.rrd")
    fmionnx.run(system_file, out=out, isolate="none")  # the next run removes it as the last's
    assert not (out / "run.rrd").exists()
