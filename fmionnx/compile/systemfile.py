"""The compiled system as a versioned file: written once, read by nodes and workers elsewhere.

A ROS 2 node on another host or a study worker gets the compiled system, not the system file:
nothing there re-reads YAML or SSP or compiles anything. The file is JSON (safe to read from
an untrusted peer, unlike a pickle) with a format name, a version, the system's content hash
and the content hash of every model file it needs. Model files travel separately and are
found *by hash* in a model store (:func:`place_models` / :func:`relocate`), so no shared file
system is assumed.

The codec is generic over the compiled system's frozen dataclasses: it follows their type
hints, so a field added to the IR is serialised without touching this module. A kind's config
is read back through the kind table (``kind`` names its class).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

from fmionnx.compile.checkir import signals_of
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.types import Ros2Plan, Ros2Settings
from fmionnx.core.datacodec import Codec
from fmionnx.core.errors import FmionnxError, ModelError
from fmionnx.core.modelfiles import NO_MODEL_FILE, ShippingError, copy_model_files
from fmionnx.core.porttotal import check_port_total
from fmionnx.core.regularfile import read_head, read_regular
from fmionnx.core.resources import ARRAY_ELEMENTS, COMPILED_FILE_BYTES, LIMIT_CODE
from fmionnx.core.safewrite import refuse, write_text_atomic
from fmionnx.core.steps import (
    MAX_EXACT_STEPS,
    count_problem,
    output_interval_problem,
    step_problem,
)
from fmionnx.core.types import Component, KindConfig
from fmionnx.kinds.base import FMI
from fmionnx.kinds.registry import COMPONENT_KINDS, config_type, has_capability, model_files

#: The ``format`` of a compiled-system file, and the versions this release reads.
FORMAT = "fmionnx-compiled-system"
VERSION = 2
#: File name suffix used by ``fmionnx compile`` and the ROS 2 supervisor.
SUFFIX = ".fmionnx.json"
#: A model's content hash as the model store names its folder.
_SHA256 = re.compile(r"[0-9a-f]{64}")


class CompiledFileError(FmionnxError):
    """A compiled-system file that cannot be used: wrong format or version, damaged, a model
    that is missing from the store or does not match its hash."""


# -- encoding -----------------------------------------------------------------------------------


def encode_value(value: Any) -> Any:
    """``value`` (a dataclass of the IR or the diagnostics, or a list of them) as JSON data,
    by the same rules as the compiled-system file."""
    return _CODEC.encode(value)


def to_json(system: CompiledSystem) -> str:
    """The compiled-system file text of ``system``."""
    document = {
        "format": FORMAT,
        "version": VERSION,
        "content_hash": system.content_hash,
        "models": {
            c.name: c.interface.content_hash for c in system.components if has_model_file(c)
        },
        "system": _CODEC.encode(system),
    }
    return json.dumps(document, indent=1, sort_keys=False) + "\n"


# -- decoding -----------------------------------------------------------------------------------

#: Names the IR only imports for type checking; the hints need them at run time.
_HINT_NAMES: dict[str, Any] = {"Ros2Plan": Ros2Plan, "Ros2Settings": Ros2Settings}


def _kind_config(base: type, data: dict[str, Any], where: str) -> type:
    """A component's config is read as the class of the kind its ``kind`` names."""
    kind = data.get("kind")
    if kind not in COMPONENT_KINDS:
        raise _CODEC.bad(f"{where}.kind", f"one of {sorted(COMPONENT_KINDS)}", kind)
    return config_type(str(kind))


#: The codec of the compiled system's dataclasses (:mod:`fmionnx.core.datacodec`).
_CODEC = Codec(
    "compiled system",
    names=_HINT_NAMES,
    error=CompiledFileError,
    resolve={KindConfig: _kind_config},
)


def _decode(hint: Any, data: Any, where: str) -> Any:
    return _CODEC.decode(hint, data, where)


def decode_value(hint: Any, data: Any, where: str) -> Any:
    """JSON ``data`` read back as ``hint`` says (the inverse of :func:`encode_value`);
    CompiledFileError names what does not fit and where."""
    try:
        return _decode(hint, data, where)
    except RecursionError:
        msg = f"{where}: nested too deeply"
        raise CompiledFileError(msg) from None


def from_json(text: str, *, origin: str = "compiled system") -> CompiledSystem:
    """Read a compiled-system file's text; CompiledFileError names what is wrong and where."""
    try:
        document = json.loads(text)
    except ValueError as exc:
        msg = f"{origin}: not a compiled-system file (invalid JSON: {exc})"
        raise CompiledFileError(msg) from None
    except RecursionError:  # a hostile file nested deeper than any compiled system is
        msg = f"{origin}: not a compiled-system file (nested too deeply)"
        raise CompiledFileError(msg) from None
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        msg = f"{origin}: not a compiled-system file (no `format: {FORMAT}`)"
        raise CompiledFileError(msg)
    if document.get("version") != VERSION:
        msg = (
            f"{origin}: compiled-system file version {document.get('version')!r}; this release "
            f"reads version {VERSION} (compile the system again with this release)"
        )
        raise CompiledFileError(msg)
    try:
        system = _decode(CompiledSystem, document.get("system"), "system")
    except RecursionError:  # e.g. a check expression nested far beyond what the compiler makes
        msg = f"{origin}: not a compiled-system file (nested too deeply)"
        raise CompiledFileError(msg) from None
    except CompiledFileError as exc:  # says where in the document; the file is said here
        raise CompiledFileError(f"{origin}: {exc}") from None
    assert isinstance(system, CompiledSystem)
    if system.content_hash != document.get("content_hash"):
        msg = f"{origin}: damaged: the system does not match its content hash"
        raise CompiledFileError(msg)
    run = system.run  # checked as when compiled: a hand-edited file could hold any numbers
    problem = step_problem(run.step) or count_problem(run.stop - run.start, run.step, "the run")
    if problem is None and run.output_interval is not None:
        problem = output_interval_problem(run.output_interval, run.step)
    if problem is not None or not run.stop > run.start:
        msg = f"{origin}: run settings out of range: {problem or 'stop is not after start'}"
        raise CompiledFileError(msg)
    for component in system.components:
        if not 1 <= component.period_steps <= MAX_EXACT_STEPS:
            msg = f"{origin}: component `{component.name}`: period_steps out of range"
            raise CompiledFileError(msg)
        _check_port_sizes(component, origin)
        if has_capability(component, FMI):  # value references are FMI's
            _check_value_references(component, origin)
    _check_references(system, origin)
    return system


#: FMI value references are 32-bit unsigned.
_LARGEST_VR = 2**32 - 1


def _check_value_references(component: Component, origin: str) -> None:
    """An FMU port's value references: whole numbers of 32 bits, one per element (FMI 2) or
    one for the whole array (FMI 3). The interface is not in the content hash (a model is
    named by its file's), so an edited file ran reading another variable, or none (a bug
    hunt: `vrs: []` gave zeros, 2**70 read value reference 0)."""
    for port in component.interface.ports:
        size = port.size
        counts = {1} if size is None else {1, size}
        bad = [vr for vr in port.vrs if not 0 <= vr <= _LARGEST_VR]
        if bad or len(port.vrs) not in counts or not all(isinstance(d, int) for d in port.shape):
            msg = (
                f"{origin}: component `{component.name}`: port `{port.name}` has value "
                f"references {list(port.vrs)[:4]} for shape {list(port.shape)}: damaged"
            )
            raise CompiledFileError(msg)


def _check_references(system: CompiledSystem, origin: str) -> None:
    """Every port the system records, connects, sets by a system input, plots or checks is a
    port of one of its components: an edited file named one that is not, and the run ended in a traceback
    (a bug hunt)."""
    ports = {(c.name, port.name) for c in system.components for port in c.interface.ports}
    named = [("`record`", ref) for ref in system.record]
    for connection in system.connections:
        named += [("a connection", connection.src), ("a connection", connection.dst)]
    for system_input in system.inputs:
        named += [(f"system input `{system_input.name}`", t.ref) for t in system_input.targets]
    for plot in system.plots:  # recorded to be drawn: a port no component has was a KeyError
        named += [(f"plot `{plot.file or plot.title}`", ref) for ref in plot.refs]
    for check in system.checks:
        read = [s.ref for s in signals_of(check.measure) if s.ref is not None]
        named += [(f"check `{check.name}`", ref) for ref in (*check.refs, *read)]
    for what, ref in named:
        if (ref.component, ref.port) not in ports:
            msg = f"{origin}: {what} names `{ref}`, which no component of the system has: damaged"
            raise CompiledFileError(msg)


def _check_port_sizes(component: Component, origin: str) -> None:
    """Port shapes within the array limit: runners size their buffers from them, and a
    file with a recomputed hash can hold any shape (the model is not re-read without a store).
    """
    try:
        largest = ARRAY_ELEMENTS.value()
    except ModelError as exc:
        raise CompiledFileError(f"{origin}: {exc}") from None
    for port in component.interface.ports:
        fixed = [d for d in port.shape if isinstance(d, int)]
        if any(d < 0 for d in fixed) or math.prod(fixed) > largest:
            msg = (
                f"{origin}: component `{component.name}`: port `{port.name}` of shape "
                f"{list(port.shape)} is out of range ({ARRAY_ELEMENTS.hint()})"
            )
            raise CompiledFileError(msg)
    try:
        check_port_total(component.interface)
    except ModelError as exc:
        msg = f"{origin}: component `{component.name}`: {exc} ({exc.hint})"
        raise CompiledFileError(msg) from None


def write_compiled(system: CompiledSystem, path: Path) -> None:
    """Write ``system`` to ``path`` atomically (a fresh temporary file renamed over it: never
    half-written, never through a link planted at ``path`` or beside it), its model paths
    made absolute: a relative one was read against the working folder of whoever ran the
    file, so the file moved, or run from its own folder, named no model (a bug hunt). (A file
    for another host finds its models in a store, by hash: ``--models``.)"""
    write_text_atomic(path, to_json(_absolute_models(system)))


def _absolute_models(system: CompiledSystem) -> CompiledSystem:
    components = []
    for component in system.components:
        if not has_model_file(component) or component.path.is_absolute():
            components.append(component)
            continue
        path = component.path.absolute()  # not resolved: a link stays a link
        interface = dataclasses.replace(component.interface, path=path)
        components.append(dataclasses.replace(component, path=path, interface=interface))
    return dataclasses.replace(system, components=tuple(components))


def _models_found(system: CompiledSystem, path: Path) -> None:
    """Every model the system names exists (CompiledFileError): a missing one was a fault of
    the run, after a results folder was made for it."""
    for component in system.components:
        if has_model_file(component) and not os.path.lexists(component.path):
            msg = (
                f"{path}: component `{component.name}`: its model `{component.path}` does not "
                "exist (moved since the system was compiled? `fmionnx compile --models STORE` "
                "keeps the models with the file, found by hash)"
            )
            raise CompiledFileError(msg)


#: How every compiled-system file this release writes begins (:func:`to_json`).
_HEADER = ('{\n "format": ' + json.dumps(FORMAT) + ",").encode()


def written_by_fmionnx(path: Path) -> bool:
    """``path`` is a regular file (not a link) that begins as a compiled system does."""
    try:
        return read_head(path, len(_HEADER), follow=False) == _HEADER
    except OSError:
        return False


def check_compile_target(output: Path, *, force: bool) -> None:
    """Raise :class:`OverwriteRefusedError` when ``output`` holds something fmionnx did not
    write (compiling again over its own file is the normal loop and needs no option)."""
    if force:
        return
    if output.is_symlink() or (output.exists() and not written_by_fmionnx(output)):
        raise refuse(output, "exists and is not a compiled system written by `fmionnx compile`")


def read_compiled(path: Path, *, models: Path | None = None) -> CompiledSystem:
    """Read a compiled-system file; with ``models``, find every model there by hash.

    The file may come from another host: its size is bounded before it is read
    (:data:`fmionnx.core.resources.COMPILED_FILE_BYTES`), since parsed JSON takes several
    times its size in memory.
    """
    try:
        largest = COMPILED_FILE_BYTES.value()
        # A FIFO or a device would never end: only a regular file is read (E011).
        data = read_regular(path, COMPILED_FILE_BYTES, "the file")
        text = data.decode("utf-8")
    except ModelError as exc:  # not a regular file, too large, a malformed limit setting
        if exc.code == LIMIT_CODE and "bytes, more than" in str(exc):
            msg = f"{path}: the compiled system is larger than {largest} bytes ({exc.hint})"
            raise CompiledFileError(msg) from None
        raise CompiledFileError(f"{path}: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        msg = f"{path}: cannot read the compiled system: {exc}"
        raise CompiledFileError(msg) from None
    system = from_json(text, origin=str(path))
    if models is not None:
        return relocate(system, models)
    _models_found(system, path)
    return system


# -- models by hash -----------------------------------------------------------------------------


def has_model_file(component: Component) -> bool:
    """False for a component defined entirely in the system file (its config is the model)."""
    return component.declared_path != NO_MODEL_FILE


def stored_model(store: Path, component: Component) -> Path:
    """Where ``component``'s model lives in a model store: ``<store>/<sha256>/<file name>``.

    Both parts come from the compiled-system file, which may have been edited: a hash that is
    not 64 hex digits or a name like ``..`` would reach outside the store, and is refused.
    """
    digest, name = component.interface.content_hash, component.path.name
    if not _SHA256.fullmatch(digest) or name in ("", ".", "..") or "\\" in name:
        msg = (
            f"component `{component.name}`: model `{name}` with hash `{digest[:70]}` "
            "does not name a file in a model store"
        )
        raise CompiledFileError(msg)
    return store / digest / name


def place_models(system: CompiledSystem, store: Path) -> list[Path]:
    """Copy every model ``system`` needs into ``store`` by content hash (what a remote host or
    worker receives); returns the paths.

    What is copied is the model's kind's to say (:func:`~fmionnx.kinds.registry.model_files`:
    a scene and the files it references, never its whole folder), as regular files inside the
    model's folder, bounded (:mod:`fmionnx.core.modelfiles`; ShippingError otherwise). Each
    model's folder is filled in a fresh staging folder and renamed into place: nothing is
    written through a link planted in the store, and nothing there is deleted.
    """
    placed = []
    for component in filter(has_model_file, system.components):
        target = stored_model(store, component)
        placed.append(target)
        if target.exists():
            # Already placed (an earlier compile, another system sharing the model), or put
            # there by hand: trusted only when it is the model, or the store would be named
            # as holding it and every node would refuse it later (nothing is replaced here).
            problem = _unlike_stored(component, target)
            if problem is not None:
                msg = f"{problem}: move it out of the store and compile again"
                raise ShippingError(msg)
            continue
        folder = target.parent
        store.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{folder.name[:16]}-", dir=store))
        try:
            files = model_files(component.kind, component.path)
            copy_model_files(component.path, files, staging)
            staging.replace(folder)
        except FileExistsError:
            pass  # placed meanwhile (by another process)
        except OSError as exc:
            msg = f"cannot place the model of `{component.name}` at `{folder}`: {exc}"
            raise ShippingError(msg) from None
        finally:
            shutil.rmtree(staging, ignore_errors=True)
    return placed


def _unlike_stored(component: Component, path: Path) -> str | None:
    """Why the model at ``path`` in a store is not ``component``'s (None: it is). Reading its
    interface is the check: the kind computes the same content hash as at compile time."""
    try:
        found = COMPONENT_KINDS[component.kind].read_interface(path, None).content_hash
    except ModelError as exc:
        return f"component `{component.name}`: {exc}"
    if found != component.interface.content_hash:
        return (
            f"component `{component.name}`: {path} does not match the compiled system "
            f"(sha256 {found[:16]}..., expected {component.interface.content_hash[:16]}...)"
        )
    return None


def relocate(system: CompiledSystem, store: Path) -> CompiledSystem:
    """``system`` with every model path pointing into ``store``, each checked against its hash.

    Reading the placed model's interface is the check (the kind computes the same content hash
    as at compile time), so a model that changed, or a store that holds the wrong file, is
    refused before anything runs.
    """
    components = []
    for component in system.components:
        if not has_model_file(component):
            components.append(component)
            continue
        path = stored_model(store, component)
        if not path.exists():
            msg = (
                f"component `{component.name}`: model {component.path.name} "
                f"(sha256 {component.interface.content_hash[:16]}...) is not in {store}"
            )
            raise CompiledFileError(msg)
        problem = _unlike_stored(component, path)
        if problem is not None:
            raise CompiledFileError(problem)
        interface = dataclasses.replace(component.interface, path=path)
        components.append(dataclasses.replace(component, path=path, interface=interface))
    return dataclasses.replace(system, components=tuple(components))
