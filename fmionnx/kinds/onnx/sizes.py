"""What an ONNX model stores and computes, bounded before onnxruntime loads it.

The element limit on ports (:mod:`.interface`) is not enough: a model of a few hundred bytes
can make onnxruntime allocate gigabytes in three other ways, each checked here when the
interface is read (so ``validate`` refuses what ``run`` would choke on):

* **stored tensors**: an initializer (or a ``Constant``, or a tensor in a subgraph) whose data
  lies in an external file declares its shape in the model, and onnxruntime allocates that
  shape when it loads the data; a sparse initializer is made dense at load, so its dense
  shape counts, not its few values. Each tensor is held to
  :data:`~fmionnx.core.resources.ARRAY_ELEMENTS`, all of them together to
  :data:`~fmionnx.core.resources.MODEL_ELEMENTS`, and every external data file must be a
  regular file within :data:`~fmionnx.core.resources.MODEL_FILE_BYTES`.
* **computed tensors**: ``Expand``, ``Tile``, ``ConstantOfShape`` and friends turn a few
  constants into a tensor of any size. ONNX shape inference with data propagation computes
  every shape that follows from the model's constants; each one fully known is held to the
  element limit. A shape that depends on input *values* cannot be known before the run:
  onnxruntime's allocator is capped instead (:mod:`.ortsetup`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import Any

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import regular_size
from fmionnx.core.resources import ARRAY_ELEMENTS, MODEL_ELEMENTS, MODEL_FILE_BYTES
from fmionnx.kinds.onnx.external import EXTERNAL, all_tensors


def _graphs(graph: Any) -> Iterator[Any]:
    """``graph`` and every subgraph of its nodes (``If``, ``Loop``, ``Scan`` bodies)."""
    yield graph
    for node in graph.node:
        for attribute in node.attribute:
            if attribute.HasField("g"):
                yield from _graphs(attribute.g)
            for inner in attribute.graphs:
                yield from _graphs(inner)


def _sparse_tensors(model: Any) -> Iterator[Any]:
    """Every sparse tensor of ``model``: initializers and node attributes, subgraphs and
    functions included."""
    nodes = [node for function in model.functions for node in function.node]
    for graph in _graphs(model.graph):
        yield from graph.sparse_initializer
        nodes.extend(graph.node)
    for node in nodes:
        for attribute in node.attribute:
            if attribute.HasField("sparse_tensor"):
                yield attribute.sparse_tensor
            yield from attribute.sparse_tensors


def _location(tensor: Any) -> str:
    return next((entry.value for entry in tensor.external_data if entry.key == "location"), "")


def check_stored_tensors(model: Any, path: Path) -> None:
    """E008 for a stored tensor (or all of them) beyond the limits, E011 for external data
    in a file that is not a regular file. Locations are already known to lie beside the model
    (:func:`~.external.check_external_data`)."""
    each, together = ARRAY_ELEMENTS.value(), MODEL_ELEMENTS.value()
    total = 0
    dense = [
        (sparse.values.name or "sparse", list(sparse.dims)) for sparse in _sparse_tensors(model)
    ]
    stored = [(tensor.name, list(tensor.dims)) for tensor in all_tensors(model)]
    for name, dims in [*stored, *dense]:
        elements = math.prod(max(0, int(d)) for d in dims)
        if elements > each:
            msg = f"`{path.name}`: stored tensor `{name}` of shape {dims} has {elements} elements"
            raise ARRAY_ELEMENTS.exceeded(msg)
        total += elements
        if total > together:
            msg = (
                f"`{path.name}`: the tensors the model stores have more than {together} "
                f"elements together (at `{name}`)"
            )
            raise MODEL_ELEMENTS.exceeded(msg)
    folder = path.parent
    for tensor in all_tensors(model):
        if tensor.data_location == EXTERNAL:
            where = folder / PurePosixPath(_location(tensor).replace("\\", "/"))
            if where.exists():  # a missing one was refused already (E010, :mod:`.external`)
                regular_size(
                    where, MODEL_FILE_BYTES, f"`{where.name}`, the data of tensor `{tensor.name}`,"
                )


def _shape(value: Any) -> list[int] | None:
    """The fully known shape of a value's tensor type; None when any dimension is not."""
    if not value.type.HasField("tensor_type") or not value.type.tensor_type.HasField("shape"):
        return None
    dims = value.type.tensor_type.shape.dim
    if not all(d.HasField("dim_value") for d in dims):
        return None
    return [int(d.dim_value) for d in dims]


def check_computed_tensors(model: Any, path: Path) -> None:
    """E008 when shape inference (with data propagation) finds a tensor the model computes
    with more elements than one tensor may have. A model shape inference cannot handle is
    left alone here (``validate`` reports it, E019, and onnxruntime refuses it)."""
    import onnx

    try:
        inferred = onnx.shape_inference.infer_shapes(model, data_prop=True)
    except Exception:  # InferenceError or the C++ core's own: not this check's to report
        return
    largest = ARRAY_ELEMENTS.value()
    for graph in _graphs(inferred.graph):
        for value in (*graph.value_info, *graph.output):
            shape = _shape(value)
            if shape is None:
                continue
            elements = math.prod(shape)
            if elements > largest:
                msg = (
                    f"`{path.name}`: the model computes `{value.name}` of shape {shape}, "
                    f"{elements} elements"
                )
                raise ARRAY_ELEMENTS.exceeded(msg)


def check_model_sizes(model: Any, path: Path) -> None:
    """Both checks above; raises ModelError (E008, E011)."""
    try:
        check_stored_tensors(model, path)
        check_computed_tensors(model, path)
    except OSError as exc:
        msg = f"`{path.name}`: cannot look at its external data: {exc.strerror}"
        raise ModelError(codes.FILE_NOT_FOUND, msg) from None
