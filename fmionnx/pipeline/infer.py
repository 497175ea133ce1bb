"""A single ONNX model inferred once (``fmionnx run model.onnx --input name=file.npy``)."""

from __future__ import annotations

import io
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from fmionnx.compile.overrides import OverrideError
from fmionnx.core.diagnostics import did_you_mean, one_of
from fmionnx.core.errors import RunError
from fmionnx.core.types import Causality
from fmionnx.pipeline.errors import RefusedError, RequestError
from fmionnx.pipeline.request import RunRequest
from fmionnx.pipeline.system import System


@dataclass(frozen=True)
class Inference:
    """The outputs of one inference (shaped like the model's) and the files written."""

    system: System
    outputs: dict[str, npt.NDArray[np.generic]]
    files: tuple[Path, ...]
    out: Path | None


def infer(request: RunRequest) -> Inference:
    """Load the model, read each input's ``.npy`` file, infer once, write one ``.npy`` per
    output into ``--out`` (when given)."""
    from fmionnx.core.safewrite import write_bytes_atomic
    from fmionnx.pipeline.run import load_request

    system = load_request(request)
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
