"""``fmionnx validate model.onnx``: the ONNX checker and strict shape inference.

Reading the interface only decodes the protobuf and lists graph inputs and outputs; a model
with a dangling edge, an unknown operator or tensors whose shapes contradict each other still
reads. ``onnx.checker.check_model`` checks the graph against the operator schemas of its
opsets, and shape inference in strict mode (types checked too) refuses what would fail when
onnxruntime loads the model. Both only read the model; nothing runs.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.core import codes
from fmionnx.kinds.base import KindProblem

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
    return ()


def _text(exc: Exception) -> str:
    lines = [line.strip() for line in str(exc).strip().splitlines() if line.strip()]
    return " ".join(lines[:_MAX_MESSAGE_LINES]) or type(exc).__name__
