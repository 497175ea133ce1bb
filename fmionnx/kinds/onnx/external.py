"""Tensors stored outside an ONNX file must stay beside it.

An ONNX model may keep large tensors in separate files: ``data_location: EXTERNAL`` with a
``location`` relative to the model's folder. onnxruntime opens whatever that location names, so
a downloaded model saying ``location: ../../../elsewhere/id_rsa`` or ``/etc/shadow`` would
make it read (and, as "weights", possibly leak through the outputs) a file the user never
meant to hand over. Every external location is therefore checked, when the interface is read
and again right before onnxruntime loads the model: it must be a relative path without ``..``
that lies inside the model's folder once links are followed (E017).

Tensors hide in more places than the initializers: sparse initializers, node attributes
(``Constant``'s ``value``), subgraphs of ``If``/``Loop``/``Scan`` and local functions; all are
walked.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import Any

from fmionnx.core import codes
from fmionnx.core.errors import ModelError

#: ``TensorProto.DataLocation.EXTERNAL``.
EXTERNAL = 1


def _sparse(tensor: Any) -> Iterator[Any]:
    yield tensor.values
    yield tensor.indices


def _node_tensors(nodes: Any) -> Iterator[Any]:
    for node in nodes:
        for attribute in node.attribute:
            if attribute.HasField("t"):
                yield attribute.t
            yield from attribute.tensors
            if attribute.HasField("sparse_tensor"):
                yield from _sparse(attribute.sparse_tensor)
            for sparse in attribute.sparse_tensors:
                yield from _sparse(sparse)
            if attribute.HasField("g"):
                yield from _graph_tensors(attribute.g)
            for graph in attribute.graphs:
                yield from _graph_tensors(graph)


def _graph_tensors(graph: Any) -> Iterator[Any]:
    yield from graph.initializer
    for sparse in graph.sparse_initializer:
        yield from _sparse(sparse)
    yield from _node_tensors(graph.node)


def all_tensors(model: Any) -> Iterator[Any]:
    """Every tensor of ``model`` (an ``onnx.ModelProto``), subgraphs and functions included."""
    yield from _graph_tensors(model.graph)
    for function in model.functions:
        yield from _node_tensors(function.node)


def _location(tensor: Any) -> str:
    return next((entry.value for entry in tensor.external_data if entry.key == "location"), "")


def has_external_data(model: Any) -> bool:
    """Whether any tensor of ``model`` keeps its data in a file of its own."""
    return any(tensor.data_location == EXTERNAL for tensor in all_tensors(model))


def check_external_data(model: Any, path: Path) -> None:
    """Raise ModelError (E017) for an external tensor of the model at ``path`` stored
    anywhere but inside the model's folder, and E010 for one whose file is missing: else a
    system would validate and fault when onnxruntime loads the model."""
    folder = path.parent.resolve()
    for tensor in all_tensors(model):
        if tensor.data_location != EXTERNAL:
            continue
        location = _location(tensor)
        where = f"`{path.name}`: tensor `{tensor.name}` is stored in `{location}`"
        normal = PurePosixPath(location.replace("\\", "/"))
        if not location or normal.is_absolute() or (len(location) > 1 and location[1] == ":"):
            msg = f"{where}: not a path relative to the model's folder"
            raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=_HINT)
        if ".." in normal.parts:
            msg = f"{where}, outside the model's folder (`..`)"
            raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=_HINT)
        if not (folder / normal).resolve().is_relative_to(folder):
            msg = f"{where}, a link to a file outside the model's folder"
            raise ModelError(codes.UNSAFE_ARCHIVE, msg, hint=_HINT)
        if not (folder / normal).exists():
            msg = f"{where}, which does not exist beside the model"
            raise ModelError(codes.FILE_NOT_FOUND, msg, hint=_MISSING_HINT)


_HINT = (
    "external tensor data must be stored beside the model (onnx.save_model(..., "
    "save_as_external_data=True, location='weights.bin'))"
)

_MISSING_HINT = "copy the model's external data file beside it, under the name the model gives"
