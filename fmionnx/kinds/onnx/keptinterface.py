"""ONNX models' interfaces, kept between processes (``<cache>/onnx-interfaces``).

Reading an ONNX model's inputs and outputs imports ``onnx`` and parses the model's protobuf:
about a tenth of a second of every compile that the compile cache cannot serve (a system file
just edited), for an answer that depends only on the model's bytes (and its name, which the
ports' origins carry), the limits in force, the reading code and the installed ``onnx``. So
the interface of a model that keeps no tensor in an external file is kept under a key of
exactly those, and a compile of an unchanged model reads it back without importing ``onnx``.
A model with external data (whose files could change without its bytes changing) is read
every time, as a model that fails is.

Entries are kept as every kept answer is (:mod:`fmionnx.core.keptentries`): private, signed
with this user's key, ignored when they do not check out or do not decode, bounded in size and
age as the compile cache is. ``FMIONNX_ONNX_INTERFACES=0`` turns the keeping off.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from pathlib import Path

from fmionnx.core.datacodec import Codec
from fmionnx.core.keptentries import Entry, KeptAnswers, installed_package
from fmionnx.core.types import ComponentInterface
from fmionnx.kinds.cache import code_stamps, module_files

#: The store: ``FMIONNX_ONNX_INTERFACES=0`` turns it off.
STORE = KeptAnswers(
    switch="FMIONNX_ONNX_INTERFACES",
    folder="onnx-interfaces",
    format="fmionnx-onnx-interface-1",
    max_bytes=16 << 20,
    file_name="interface.json",
)

#: How interfaces are written and read back (:mod:`fmionnx.core.datacodec`).
_CODEC = Codec("kept ONNX interface")


def kept_interface(path: Path) -> ComponentInterface:
    """The interface of the ONNX model at ``path``: a kept one when an entry checks out, else
    read with ``onnx`` (and kept when the model has no external data). Raises ModelError as
    reading the model does."""
    from fmionnx.core.errors import ModelError
    from fmionnx.kinds.onnx import interface

    if not STORE.enabled():
        return interface.read_signature(path)[0]
    try:
        data: bytes | None = interface.read_model_bytes(path)
    except ModelError:
        data = None  # reading the signature reports it
    entry = _entry(path, data) if data is not None else None
    if entry is not None:
        found = STORE.read_value(entry, _CODEC, ComponentInterface)
        if found is not None:
            return dataclasses.replace(found, path=path)
    read, external = interface.read_signature(path, data)
    if entry is not None and not external:
        STORE.write_value(entry, _CODEC, read)
    return read


def _entry(path: Path, data: bytes) -> Entry | None:
    """The entry of the model at ``path`` whose bytes are ``data``; None when ``onnx`` cannot
    be stamped (the model is then read, and its errors reported, as without this module)."""
    code = _code_stamps()
    if code is None:
        return None
    return STORE.entry([path.name, hashlib.sha256(data).hexdigest(), *code])


@functools.cache
def _code_stamps() -> tuple[str, ...] | None:
    """``onnx``'s installed package (found without importing it) and fmionnx's modules that
    read a model and define what an entry holds."""
    from fmionnx.core import datacodec, keptentries, types, units
    from fmionnx.kinds.onnx import external, interface, sizes

    package = installed_package("onnx")
    if package is None:
        return None
    readers = module_files(interface, external, sizes, types, units, datacodec, keptentries)
    return code_stamps([package / "__init__.py"], [*readers, Path(__file__)])
