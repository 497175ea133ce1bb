"""Read an ONNX model's signature: graph inputs (minus initializers) and outputs.

Before the signature is trusted, external tensor data is checked to stay beside the model
(:mod:`.external`, E017) and every tensor shape against the element limit (E008): the runner
allocates a buffer per input from these shapes.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from pathlib import Path
from typing import Any

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span
from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import read_regular
from fmionnx.core.resources import ARRAY_ELEMENTS, MODEL_FILE_BYTES
from fmionnx.core.types import Causality, ComponentInterface, DType, Port
from fmionnx.kinds.base import UNLISTED_FILES
from fmionnx.kinds.cache import cached_interface, file_identity
from fmionnx.kinds.onnx.external import EXTERNAL, all_tensors, check_external_data
from fmionnx.kinds.onnx.sizes import check_model_sizes

#: ONNX ``TensorProto.DataType`` numbers -> fmionnx dtypes.
_DTYPES = {
    1: DType.FLOAT32,
    2: DType.UINT8,
    3: DType.INT8,
    4: DType.UINT16,
    5: DType.INT16,
    6: DType.INT32,
    7: DType.INT64,
    8: DType.STRING,
    9: DType.BOOL,
    11: DType.FLOAT64,
    12: DType.UINT32,
    13: DType.UINT64,
}


def read_onnx_interface(path: Path) -> ComponentInterface:
    """The ports and facts of the ONNX model at ``path``."""
    if not path.exists():
        msg = f"`{path}` does not exist"
        raise ModelError(codes.FILE_NOT_FOUND, msg)
    if not path.is_file():
        msg = f"`{path}` is a directory or special file, not an ONNX model"
        raise ModelError(codes.NOT_A_FILE, msg)
    from fmionnx.kinds.onnx.keptinterface import kept_interface

    return cached_interface(("onnx", *file_identity(path)), path, lambda: kept_interface(path))


def read_model_bytes(path: Path) -> bytes:
    """The bytes of the ONNX model at ``path`` (a regular file within the size limit).

    Raises ModelError: E011 not a regular file, E008 too large, E001 unreadable.
    """
    try:
        return read_regular(path, MODEL_FILE_BYTES, f"the ONNX model `{path.name}`")
    except OSError as exc:
        msg = f"cannot read `{path}`: {exc.strerror}"
        raise ModelError(codes.FILE_NOT_FOUND, msg) from None


def parse_checked_model(data: bytes, path: Path) -> Any:
    """The ``onnx.ModelProto`` of ``data`` (read from ``path``), external data checked.

    Raises ModelError: E012 not a model, E017 external data outside the model's folder.
    """
    import onnx
    from google.protobuf.message import DecodeError

    try:
        model = onnx.load_model_from_string(data)
    except (DecodeError, ValueError, RuntimeError) as exc:
        msg = f"`{path}` is not an ONNX model (protobuf could not be decoded: {exc})"
        raise ModelError(codes.BAD_MODEL, msg) from None
    check_external_data(model, path)
    return model


def read_signature(path: Path, data: bytes | None = None) -> tuple[ComponentInterface, bool]:
    """The interface of the model at ``path`` (whose bytes are ``data`` when the caller has
    read them already) read with ``onnx``, and whether the model keeps a tensor in an
    external file."""
    if data is None:
        data = read_model_bytes(path)
    model = parse_checked_model(data, path)
    external = any(t.data_location == EXTERNAL for t in all_tensors(model))
    interface = _interface(model, data, path)
    if external:  # its tensors' files are not the model's: compiles of it are not kept
        interface = dataclasses.replace(
            interface, facts=(*interface.facts, (UNLISTED_FILES, "true"))
        )
    return interface, external


def _interface(model: Any, data: bytes, path: Path) -> ComponentInterface:
    graph = model.graph
    if not graph.output:
        msg = f"`{path}` is not an ONNX model with a graph (no outputs)"
        raise ModelError(codes.BAD_MODEL, msg)
    initializers = {i.name for i in graph.initializer}
    inputs = [v for v in graph.input if v.name not in initializers]
    input_names = tuple(v.name for v in inputs)
    ports = [_port(v, Causality.INPUT, path, None) for v in inputs]
    ports += [_port(v, Causality.OUTPUT, path, input_names) for v in graph.output]
    _check_unique(ports, path)
    check_model_sizes(model, path)  # what it stores and computes (E008, E011)
    opset = next((o.version for o in model.opset_import if o.domain in ("", "ai.onnx")), 0)
    facts = [
        ("irVersion", str(model.ir_version)),
        ("opset", str(opset)),
        ("producer", f"{model.producer_name} {model.producer_version}".strip()),
        ("graphName", graph.name),
        ("docString", (model.doc_string or graph.doc_string).strip()),
        ("signature", _signature(ports)),
    ]
    facts += [(f"metadata.{p.key}", p.value) for p in model.metadata_props]
    return ComponentInterface(
        kind="onnx",
        path=path,
        ports=tuple(ports),
        facts=tuple(facts),
        content_hash=hashlib.sha256(data).hexdigest(),
    )


def _check_unique(ports: list[Port], path: Path) -> None:
    """E013 for a name two ports share: an output named like an input (a graph passing its
    input through) or two outputs of one name. Ports are found by name, so the second would
    hide the first (``p.x -> h.u`` then said `p.x` is an input), as MuJoCo's names do."""
    seen: dict[str, Causality] = {}
    for port in ports:
        first = seen.get(port.name)
        if first is not None:
            both = f"an {first.value} and an {port.causality.value}"
            if first is port.causality:
                both = f"two {first.value}s"
            msg = f"`{path.name}`: the name `{port.name}` is used by {both}; port names must be unique"
            hint = "rename one of them in the graph (an Identity node gives an output its own name)"
            raise ModelError(codes.UNSUPPORTED_MODEL, msg, hint=hint)
        seen[port.name] = port.causality


def _port(value: Any, causality: Causality, path: Path, depends: tuple[str, ...] | None) -> Port:
    tensor = value.type.tensor_type
    if not value.type.HasField("tensor_type") or tensor.elem_type not in _DTYPES:
        msg = f"`{path}`: {causality.value} `{value.name}` is not a tensor of a supported type"
        raise ModelError(
            codes.UNSUPPORTED_MODEL, msg, hint="fmionnx connects tensor inputs and outputs"
        )
    shape: list[int | str] = []
    for dim in tensor.shape.dim:
        if dim.HasField("dim_value"):
            shape.append(int(dim.dim_value))
        elif dim.dim_param:
            shape.append(str(dim.dim_param))
        else:
            shape.append("?")
    _check_shape(value.name, causality, shape, path)
    return Port(
        name=value.name,
        causality=causality,
        dtype=_DTYPES[tensor.elem_type],
        shape=tuple(shape),
        description=value.doc_string or "",
        depends_on=depends,
        origin=Span(Path(path.name)),
    )


def _check_shape(name: str, causality: Causality, shape: list[int | str], path: Path) -> None:
    """E012 for a negative dimension, E013 for an empty one (a zero-size tensor is valid ONNX,
    but a port of no numbers carries nothing); E008 when the fixed dimensions exceed the limit.

    Symbolic dimensions count as 1 here, as in the runner; a connection that fills one is
    bounded by the port on its other end.
    """
    fixed = [d for d in shape if isinstance(d, int)]
    if any(d < 0 for d in fixed):
        msg = f"`{path.name}`: {causality.value} `{name}` has a negative dimension {shape}"
        raise ModelError(codes.BAD_MODEL, msg)
    if 0 in fixed:
        msg = f"`{path.name}`: {causality.value} `{name}` has a dimension of 0 {shape}"
        raise ModelError(codes.UNSUPPORTED_MODEL, msg, hint="a port carries at least one number")
    elements = math.prod(fixed)
    if elements > ARRAY_ELEMENTS.value():
        msg = f"`{path.name}`: {causality.value} `{name}` of shape {shape} has {elements} elements"
        raise ARRAY_ELEMENTS.exceeded(msg)


def _signature(ports: list[Port]) -> str:
    return "; ".join(
        f"{p.causality.value} {p.name}: {p.dtype}{'' if p.is_scalar else p.shape_text()}"
        for p in ports
    )
