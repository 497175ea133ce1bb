"""``fmionnx validate model.onnx``: the ONNX checker and strict shape inference.

Reading the interface only decodes the protobuf and lists graph inputs and outputs; a model
with a dangling edge, an unknown operator or tensors whose shapes contradict each other still
reads. ``onnx.checker.check_model`` checks the graph against the operator schemas of its
opsets, and shape inference in strict mode (types checked too) refuses what would fail when
onnxruntime loads the model. Both only read the model; nothing runs.

Neither knows the onnxruntime installed: a model stamped with an opset or IR version newer
than it implements (``onnx`` may know more than the runtime, and does not refuse an opset it
does not know), or with a node of a custom domain it has no kernel for, passed and was refused
only by ``run``. onnxruntime keeps those maxima in its native library, so no table kept here
would stay exact; the lone model's check therefore asks onnxruntime itself: it loads the model
into a session (graph optimisations off, one thread, nothing run). A system's ``validate``
does not import onnxruntime (it starts fast); ``validate MODEL.onnx`` is the deep check.
"""

from __future__ import annotations

import re
from pathlib import Path

from fmionnx.core import codes
from fmionnx.kinds.base import KindProblem
from fmionnx.kinds.onnx.external import has_external_data

#: A checker message is a paragraph; its first lines say what is wrong.
_MAX_MESSAGE_LINES = 3


def validate_onnx_model(path: Path) -> tuple[KindProblem, ...]:
    """E019 for the checker's or shape inference's first complaint, else nothing."""
    import onnx
    from onnx.checker import ValidationError

    from fmionnx.core.errors import ModelError
    from fmionnx.core.regularfile import read_regular
    from fmionnx.core.resources import MODEL_FILE_BYTES

    # The interface was read first (and refused a special or oversized file); read the same
    # way again, since the file may have been swapped meanwhile.
    try:
        data = read_regular(path, MODEL_FILE_BYTES, f"the ONNX model `{path.name}`")
    except ModelError as exc:
        return (KindProblem(exc.code, str(exc), "path", exc.hint),)
    except OSError as exc:
        return (
            KindProblem(codes.FILE_NOT_FOUND, f"cannot read `{path.name}`: {exc.strerror}", "path"),
        )
    model = onnx.load_model_from_string(data)
    try:
        onnx.checker.check_model(model)
    except ValidationError as exc:
        return (
            KindProblem(
                codes.INVALID_MODEL, f"the ONNX checker refuses the model: {_text(exc)}", "path"
            ),
        )
    except Exception as exc:  # the checker's C++ core may raise others: still the model's fault
        return (KindProblem(codes.INVALID_MODEL, f"the ONNX checker fails: {_text(exc)}", "path"),)
    try:
        onnx.shape_inference.infer_shapes(model, check_type=True, strict_mode=True)
    except Exception as exc:  # InferenceError, or another error of the C++ core
        message = f"ONNX shape inference fails: {_text(exc)}"
        return (KindProblem(codes.INVALID_MODEL, message, "path"),)
    return _runtime_refusal(data if not has_external_data(model) else path)


def _runtime_refusal(source: bytes | Path) -> tuple[KindProblem, ...]:
    """E019 when the installed onnxruntime cannot load the model (an opset or IR version
    beyond it, an operator of a domain it has no kernel for), else nothing. Without
    onnxruntime installed there is nothing to ask: ``run`` says what is missing."""
    from fmionnx.core.errors import ModelError
    from fmionnx.kinds.onnx.ortsetup import onnxruntime_module, session_options

    try:
        ort = onnxruntime_module()
    except ImportError:
        return ()
    except ModelError as exc:  # a malformed memory ceiling: the run would refuse it too
        return (KindProblem(exc.code, str(exc), "path", exc.hint),)
    options = session_options(ort)
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_DISABLE_ALL
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    options.log_severity_level = 3  # its own warnings are not the model's fault
    model = str(source) if isinstance(source, Path) else source
    try:
        ort.InferenceSession(model, sess_options=options, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own Fail, InvalidGraph, ...
        message = f"onnxruntime {ort.__version__} cannot load the model: {_runtime_text(exc)}"
        hint = (
            "export the model for the opsets this onnxruntime implements, or install one that "
            "implements the model's (a custom operator needs a kernel onnxruntime has)"
        )
        return (KindProblem(codes.INVALID_MODEL, message, "path", hint),)
    return ()


#: onnxruntime's message starts with its status and the C++ function that failed:
#: ``[ONNXRuntimeError] : 1 : FAIL : /src/model.cc:256 onnxruntime::Model::Model(...) ``.
_RUNTIME_PREFIX = re.compile(r"^\[ONNXRuntimeError\] : \d+ : \w+ : (?:\S+:\d+ [^(]*\([^)]*\) )?")


def _runtime_text(exc: Exception) -> str:
    """onnxruntime's reason, without its status code and source location."""
    return _RUNTIME_PREFIX.sub("", _text(exc)).strip() or type(exc).__name__


def _text(exc: Exception) -> str:
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    return " ".join(lines[:_MAX_MESSAGE_LINES]) or type(exc).__name__
