"""A single ONNX model inferred once (``fmionnx run model.onnx --input name=file.npy``).

The CLI and :func:`fmionnx.run` reach it alike through the run pipeline
(:func:`~fmionnx.pipeline.run.execute`): a bug hunt found the API running an ``.onnx`` target
as a two-step system from its start values, its ``inputs`` ignored.
"""

from __future__ import annotations

import io
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from fmionnx.compile.overrides import OverrideError
from fmionnx.core.diagnostics import did_you_mean, one_of
from fmionnx.core.errors import RunError
from fmionnx.core.signals import column_names
from fmionnx.core.types import Causality
from fmionnx.pipeline.errors import EXIT_OK, RefusedError, RequestError
from fmionnx.pipeline.outcome import RunOutcome
from fmionnx.pipeline.request import RunRequest
from fmionnx.pipeline.system import System
from fmionnx.runtime.result import RunResult, RunStatus


@dataclass(frozen=True)
class Inference:
    """The outputs of one inference (shaped like the model's) and the files written."""

    system: System
    outputs: dict[str, npt.NDArray[np.generic]]
    files: tuple[Path, ...]
    out: Path | None


@dataclass(frozen=True)
class InferenceOutcome(RunOutcome):
    """A single ONNX model's inference as a run's outcome: ``outputs`` holds each output
    shaped like the model's; ``result`` has them as one row at the start time, named as a
    run of the model would name its columns (``outcome["model.y[0]"]``), so that code
    reading a :class:`RunOutcome` reads this one too."""

    outputs: Mapping[str, npt.NDArray[np.generic]] = field(default_factory=dict)


def inference_outcome(request: RunRequest, system: System | None = None) -> InferenceOutcome:
    """:func:`infer` as the pipeline's outcome: what ``fmionnx run model.onnx`` and
    ``fmionnx.run("model.onnx", inputs=...)`` both return."""
    began = time.perf_counter()
    done = infer(request, system)
    compiled = done.system.compiled
    component = compiled.components[0]
    signals = {}
    for port in component.interface.with_causality(Causality.OUTPUT):
        value = done.outputs.get(port.name)
        if value is None or value.dtype.kind not in "biuf":
            continue  # a string tensor has no column
        flat = np.asarray(value, dtype=np.float64).reshape(-1)
        names = column_names(component.name, port)
        if len(names) != flat.size:  # a dimension known only now: flat indices
            names = [f"{component.name}.{port.name}[{i}]" for i in range(flat.size)]
        for name, item in zip(names, flat, strict=True):
            signals[name] = np.array([item], dtype=np.float64)
    result = RunResult.after(
        compiled, "inprocess", RunStatus.COMPLETED, 0, time.perf_counter() - began, signals
    )
    return InferenceOutcome(
        done.system, result, (), done.files, done.out, EXIT_OK, outputs=dict(done.outputs)
    )


def infer(request: RunRequest, system: System | None = None) -> Inference:
    """Load the model (unless ``system`` is it, loaded), read each input's ``.npy`` file,
    infer once, write one ``.npy`` per output into ``--out`` (when given)."""
    from fmionnx.core.safewrite import write_bytes_atomic
    from fmionnx.pipeline.run import load_request

    _refuse_run_over_time(request)
    if system is None:
        system = load_request(request)
    system = _with_params(system, request)
    arrays = {}
    for name, file in request.inputs:
        try:
            arrays[name] = np.load(file, allow_pickle=False)
        except (OSError, ValueError) as exc:
            msg = f"--input {name}: cannot read `{file}` as a .npy array ({exc})"
            raise RequestError(msg) from None
    try:
        outputs = run_onnx_once(system, arrays)
    except (OverrideError, RunError) as exc:
        raise RefusedError(str(exc)) from None
    files = []
    out = request.output.out
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        for name, value in outputs.items():
            buffer = io.BytesIO()  # written atomically: never through a link planted there
            np.save(buffer, value)
            files.append(write_bytes_atomic(out / f"{name}.npy", buffer.getvalue()))
    return Inference(system, outputs, tuple(files), out)


def _refuse_run_over_time(request: RunRequest) -> None:
    """``--stop-time`` ends a run over time: an inference has none, and the time was dropped
    without a word (the request refuses ``--step`` and the other times already)."""
    if request.overrides.stop_time is not None:
        msg = "--stop-time applies to systems and FMUs, not to a single ONNX model's inference"
        raise RequestError(msg)


def _with_params(system: System, request: RunRequest) -> System:
    """``system`` with the request's ``--param`` values set on the model's inputs, as a
    system file's ``parameters:`` sets an ONNX component's unconnected inputs: a bug hunt
    found them dropped without a word, an unknown name too. A name the model has no input
    of is refused naming the inputs it has; one also given by ``--input`` is refused (two
    values for one input, the file's silently winning)."""
    params = dict(request.overrides.params)
    if not params:
        return system
    try:
        changed = system.with_overrides(params=params)
    except OverrideError as exc:
        raise RequestError(str(exc)) from None
    twice = sorted(set(params).intersection(name for name, _ in request.inputs))
    if twice:
        msg = (
            f"--param and --input both give the input `{twice[0]}`: give it one value "
            "(--input for an array from a .npy file, --param for a value written out)"
        )
        raise RequestError(msg)
    return changed


def run_onnx_once(
    system: System, inputs: Mapping[str, npt.ArrayLike]
) -> dict[str, npt.NDArray[np.generic]]:
    """Run a one-ONNX-model system once on ``inputs``; returns outputs shaped like the model's."""
    from fmionnx.core.runner import Wiring, get_output, set_input
    from fmionnx.kinds.registry import make_runner

    component = system.compiled.components[0]
    expected = {p.name: p for p in component.interface.with_causality(Causality.INPUT)}
    unknown = [n for n in inputs if n not in expected]
    if unknown:
        hint = did_you_mean(unknown[0], expected) or one_of(expected)
        msg = f"the model has no input `{unknown[0]}`; {hint}"
        raise OverrideError(msg)
    sizes = {n: int(np.asarray(v).size) for n, v in inputs.items()}
    runner = make_runner(component, Wiring(frozenset(inputs), sizes))
    runner.instantiate()
    try:
        runner.setup(0.0, 1.0)
        for name, value in inputs.items():
            array = np.asarray(value)
            buffer = runner.input_buffer(name)
            if array.size != buffer.size:
                port = expected[name]
                msg = (
                    f"input `{name}` needs {buffer.size} elements (shape {port.shape_text()}), "
                    f"got an array of shape {list(array.shape)}"
                )
                raise OverrideError(msg)
            set_input(runner, name, array)
        runner.step(0.0, 1.0)
        outputs = {}
        for port in component.interface.with_causality(Causality.OUTPUT):
            outputs[port.name] = get_output(runner, port.name)
        return outputs
    finally:
        runner.terminate()
