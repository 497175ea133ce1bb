"""Load the kernel library with ctypes, once it is proven to be the one built, with our ABI.

Which library (``FMIONNX_NATIVE``, read by :mod:`.grouping`): by default the one built when
fmionnx was installed, beside this module (``setup.py``); with ``build``, one compiled at run
time into a cache (:mod:`.runbuild`). Either is loaded only if

1. its bytes have the sha256 its build manifest records and it was built from the
   ``fmi2_group.c`` beside this module (:func:`.manifest.check_built`, before ``CDLL``), and
2. after ``CDLL``, ``fx_abi_version()`` equals :data:`ABI_VERSION` and ``fx_abi_layout()``
   gives the ``sizeof`` and field offsets of the ctypes mirrors below, so a kernel and a
   Python side that disagree on a struct never exchange one.

Nothing here raises: a missing or refused library gives the reason, and the master keeps its
Python path and says why (``run.json`` ``execution.native_reason``).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from fmionnx.runtime.native.manifest import LIBRARY_NAME, SOURCE_NAME, check_built
from fmionnx.runtime.native.runbuild import build_in_cache

#: Environment switch: ``0`` keeps every component in the Python path, ``build`` compiles
#: the kernel at run time instead of loading the installed one, unset or ``1`` loads that.
#: Defined here rather than in :mod:`.grouping` so that an isolated child reads it without
#: importing the compiled system's types (and pydantic).
SWITCH_ENV = "FMIONNX_NATIVE"
#: Its values; any other keeps the Python path, with that as the reason.
SETTINGS = ("", "1", "0", "build")

#: ``FX_ABI_VERSION`` of the ``fmi2_group.c`` these mirrors follow (bump both together).
ABI_VERSION = 4

#: Where the installed library is: beside this module and its source.
INSTALLED = Path(__file__).parent
SOURCE = INSTALLED / SOURCE_NAME

#: How to get an installed library that fits.
INSTALL_HINT = "`pip install .`, or `make setup` in a source checkout"

#: Where a loaded library came from: built when fmionnx was installed, or at run time.
Origin = Literal["installed", "build"]


class Group(ctypes.Structure):
    """``fx_group`` of ``fmi2_group.c`` (field order and types must match)."""

    _fields_ = (
        ("n_members", ctypes.c_size_t),
        ("members", ctypes.c_void_p),
        ("transfers", ctypes.c_void_p),
        ("calls", ctypes.c_void_p),
        ("failed_member", ctypes.c_size_t),
        ("failed_transfer", ctypes.c_size_t),
        ("failed_call", ctypes.c_size_t),
        ("failed_status", ctypes.c_int),
    )


class Member(ctypes.Structure):
    """``fx_member`` of ``fmi2_group.c``."""

    _fields_ = (
        ("instance", ctypes.c_void_p),
        ("do_step", ctypes.c_void_p),
        ("fmi3", ctypes.c_int),
        ("event_handling_needed", ctypes.c_void_p),
        ("terminate_simulation", ctypes.c_void_p),
        ("early_return", ctypes.c_void_p),
        ("last_successful_time", ctypes.c_void_p),
        ("first_set", ctypes.c_size_t),
        ("n_set", ctypes.c_size_t),
        ("first_get", ctypes.c_size_t),
        ("n_get", ctypes.c_size_t),
        ("first_transfer", ctypes.c_size_t),
        ("n_transfers", ctypes.c_size_t),
    )


class TransferSpec(ctypes.Structure):
    """``fx_transfer`` of ``fmi2_group.c``."""

    _fields_ = (
        ("src", ctypes.c_void_p),
        ("dst", ctypes.c_void_p),
        ("count", ctypes.c_size_t),
        ("factor", ctypes.c_double),
        ("offset", ctypes.c_double),
        ("identity", ctypes.c_int),
        ("src_type", ctypes.c_int),
        ("dst_type", ctypes.c_int),
    )


class CallSpec(ctypes.Structure):
    """``fx_call`` of ``fmi2_group.c``: one get or set call of one value type."""

    _fields_ = (
        ("function", ctypes.c_void_p),
        ("vrs", ctypes.c_void_p),
        ("n_vrs", ctypes.c_size_t),
        ("values", ctypes.c_void_p),
        ("n_values", ctypes.c_size_t),
        ("type", ctypes.c_int),
        ("setter", ctypes.c_int),
    )


class TrackSpec(ctypes.Structure):
    """``fx_track`` of ``fmi2_group.c``: one recorder track that ``fx_group_run`` samples."""

    _fields_ = (
        ("rows", ctypes.c_void_p),
        ("published", ctypes.c_void_p),
        ("capacity", ctypes.c_size_t),
        ("count", ctypes.c_size_t),
        ("width", ctypes.c_size_t),
        ("first_view", ctypes.c_size_t),
        ("n_views", ctypes.c_size_t),
    )


class ViewSpec(ctypes.Structure):
    """``fx_view`` of ``fmi2_group.c``: one recorded buffer of a track."""

    _fields_ = (
        ("src", ctypes.c_void_p),
        ("count", ctypes.c_size_t),
        ("column", ctypes.c_size_t),
        ("type", ctypes.c_int),
    )


class RunSpec(ctypes.Structure):
    """``fx_run`` of ``fmi2_group.c``: the communication points ``fx_group_run`` steps."""

    _fields_ = (
        ("start", ctypes.c_double),
        ("step", ctypes.c_double),
        ("h", ctypes.c_double),
        ("n_tracks", ctypes.c_size_t),
        ("tracks", ctypes.c_void_p),
        ("views", ctypes.c_void_p),
        ("marker_t", ctypes.c_void_p),
        ("budget", ctypes.c_double),
        ("next", ctypes.c_size_t),
    )


class SpinSpec(ctypes.Structure):
    """``fx_spin`` of ``fmi2_group.c``: a hybrid wait's spin (:class:`~fmionnx.runtime.isolated.channel.Spinner`'s rules)."""

    _fields_ = (
        ("budget_ns", ctypes.c_int64),
        ("polite", ctypes.c_int),
        ("max_backoff", ctypes.c_int),
        ("backoff", ctypes.c_int),
        ("skip", ctypes.c_int),
        ("spins", ctypes.c_uint64),
        ("hits", ctypes.c_uint64),
    )


class LinkSpec(ctypes.Structure):
    """``fx_link`` of ``fmi2_group.c``: the supervisor's end of an isolated step hand-over."""

    _fields_ = (
        ("commands", ctypes.c_int),
        ("replies", ctypes.c_int),
        ("requests", ctypes.c_void_p),
        ("answers", ctypes.c_void_p),
        ("sent", ctypes.c_uint32),
        ("answered", ctypes.c_uint32),
        ("timeout_ms", ctypes.c_int),
        ("tag", ctypes.c_int),
        ("error", ctypes.c_int),
        ("spin", SpinSpec),
    )


class CopySpec(ctypes.Structure):
    """``fx_copy`` of ``fmi2_group.c``: ``size`` bytes from ``src`` to ``dst``."""

    _fields_ = (
        ("dst", ctypes.c_void_p),
        ("src", ctypes.c_void_p),
        ("size", ctypes.c_size_t),
    )


class ServerSpec(ctypes.Structure):
    """``fx_server`` of ``fmi2_group.c``: an isolated child's end of the step hand-over."""

    _fields_ = (
        ("commands", ctypes.c_int),
        ("replies", ctypes.c_int),
        ("requests", ctypes.c_void_p),
        ("answers", ctypes.c_void_p),
        ("phase", ctypes.c_void_p),
        ("times", ctypes.c_void_p),
        ("consumed", ctypes.c_uint32),
        ("written", ctypes.c_uint32),
        ("first_phase", ctypes.c_int),
        ("op", ctypes.c_int),
        ("code", ctypes.c_int),
        ("error", ctypes.c_int),
        ("group", ctypes.c_void_p),
        ("inputs", ctypes.c_void_p),
        ("n_inputs", ctypes.c_size_t),
        ("outputs", ctypes.c_void_p),
        ("n_outputs", ctypes.c_size_t),
        ("spin", SpinSpec),
    )


#: The mirrors in the order of ``fx_abi_layout``, with their C names.
MIRRORS: tuple[tuple[str, type[ctypes.Structure]], ...] = (
    ("fx_group", Group),
    ("fx_member", Member),
    ("fx_transfer", TransferSpec),
    ("fx_call", CallSpec),
    ("fx_track", TrackSpec),
    ("fx_view", ViewSpec),
    ("fx_run", RunSpec),
    ("fx_spin", SpinSpec),
    ("fx_link", LinkSpec),
    ("fx_copy", CopySpec),
    ("fx_server", ServerSpec),
)

#: The element types the kernel converts and passes to FMI calls, by their ``FX_*`` code
#: (the index): the numpy dtypes of the runners' value buffers. ``fx_abi_layout`` ends with
#: their C sizes, which must be the ctypes sizes the buffers were made with.
ELEMENT_TYPES: tuple[tuple[str, type[ctypes._SimpleCData[Any]]], ...] = (
    ("float64", ctypes.c_double),
    ("float32", ctypes.c_float),
    ("int8", ctypes.c_int8),
    ("uint8", ctypes.c_uint8),
    ("int16", ctypes.c_int16),
    ("uint16", ctypes.c_uint16),
    ("int32", ctypes.c_int32),
    ("uint32", ctypes.c_uint32),
    ("int64", ctypes.c_int64),
    ("uint64", ctypes.c_uint64),
    ("bool", ctypes.c_bool),
)

#: ``FX_*`` code of a numpy dtype name.
TYPE_CODES = {name: code for code, (name, _) in enumerate(ELEMENT_TYPES)}

#: Return codes of ``fx_group_step``, and ``fx_group_run``'s own: a track is full.
OK, NONFINITE, SET, DO_STEP, GET, TERMINATE, FULL = 0, 1, 2, 3, 4, 5, 6

#: Return codes of ``fx_link_step`` and ``fx_serve`` (:mod:`fmionnx.runtime.isolated.handover`).
LINK_REPLY, LINK_BROKEN, LINK_TIMEOUT, LINK_CLOSED, LINK_INTERRUPTED, LINK_ERRNO = range(6)
SERVE_COMMAND, SERVE_FAULT = 6, 7


@dataclass(frozen=True)
class Kernel:
    """The loaded library's functions: ``step(group, t, h) -> code`` (one communication
    point), ``run(group, run, first, last) -> code`` (many: :mod:`.bulk`), and the two ends of
    an isolated FMU's step hand-over, ``link_step(link, spin) -> code`` and
    ``serve(server) -> code`` (:mod:`fmionnx.runtime.isolated.handover`)."""

    path: Path
    origin: Origin
    sha256: str
    step: Callable[..., int]
    run: Callable[..., int]
    link_step: Callable[..., int]
    serve: Callable[..., int]


def expected_layout() -> list[tuple[str, int]]:
    """What ``fx_abi_layout`` must give: per mirror its sizeof, then each field's offset."""
    entries: list[tuple[str, int]] = []
    for c_name, mirror in MIRRORS:
        entries.append((f"sizeof({c_name})", ctypes.sizeof(mirror)))
        for field in mirror._fields_:
            name = field[0]
            entries.append((f"offsetof({c_name}, {name})", getattr(mirror, name).offset))
    for name, ctype in ELEMENT_TYPES:
        entries.append((f"sizeof({name})", ctypes.sizeof(ctype)))
    return entries


def abi_problem(dll: ctypes.CDLL) -> str | None:
    """Why ``dll`` does not fit the mirrors of this module, or None when it does."""
    try:
        version_of, layout_of = dll.fx_abi_version, dll.fx_abi_layout
    except AttributeError:
        return "it exports no fx_abi_version/fx_abi_layout (built from an older fmi2_group.c)"
    version_of.argtypes = ()
    version_of.restype = ctypes.c_uint
    layout_of.argtypes = (ctypes.POINTER(ctypes.c_size_t), ctypes.c_size_t)
    layout_of.restype = ctypes.c_size_t
    version = int(version_of())
    if version != ABI_VERSION:
        return f"its ABI version is {version}, this fmionnx expects {ABI_VERSION}"
    expected = expected_layout()
    layout = (ctypes.c_size_t * len(expected))()
    count = int(layout_of(layout, len(expected)))
    if count != len(expected):
        return f"it describes {count} struct layout entries, the ctypes mirrors {len(expected)}"
    for (what, mirrored), actual in zip(expected, layout, strict=True):
        if actual != mirrored:
            return f"{what} is {actual} in the library, {mirrored} in the ctypes mirror"
    return None


#: Libraries loaded in this process, by path and sha256 (each is loaded and checked once).
_LOADED: dict[tuple[Path, str], Kernel] = {}


def load_library(folder: Path, origin: Origin, source: Path = SOURCE) -> Kernel | str:
    """``folder``'s library if its manifest and its ABI check out; else why not."""
    verified = check_built(folder, source)
    if isinstance(verified, str):
        return verified
    key = (verified.path, verified.sha256)
    if key in _LOADED:
        return _LOADED[key]
    try:
        dll = ctypes.CDLL(str(verified.path))
    except OSError as exc:
        return f"loading {verified.path} failed: {exc}"
    problem = abi_problem(dll)
    if problem is not None:
        return f"{verified.path} does not fit this fmionnx: {problem}; refusing to use it"
    step = dll.fx_group_step
    step.argtypes = (ctypes.c_void_p, ctypes.c_double, ctypes.c_double)
    step.restype = ctypes.c_int
    run = dll.fx_group_run
    run.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_size_t)
    run.restype = ctypes.c_int
    link_step = dll.fx_link_step
    link_step.argtypes = (ctypes.c_void_p, ctypes.c_int)
    link_step.restype = ctypes.c_int
    serve = dll.fx_serve
    serve.argtypes = (ctypes.c_void_p,)
    serve.restype = ctypes.c_int
    kernel = Kernel(verified.path, origin, verified.sha256, step, run, link_step, serve)
    _LOADED[key] = kernel
    return kernel


def load_installed() -> Kernel | str:
    """The library built when fmionnx was installed; else why it cannot be used."""
    if not (INSTALLED / LIBRARY_NAME).is_file():
        return (
            f"the native kernel {LIBRARY_NAME} is not installed (it is built when fmionnx is "
            f"installed: {INSTALL_HINT}; FMIONNX_NATIVE=build compiles it at run time instead)"
        )
    kernel = load_library(INSTALLED, "installed")
    if isinstance(kernel, str):
        return f"{kernel} (install fmionnx again to rebuild it: {INSTALL_HINT})"
    return kernel


def load_kernel(*, build: bool) -> Kernel | str:
    """The installed kernel, or with ``build`` one compiled at run time; else why not."""
    if not build:
        return load_installed()
    folder = build_in_cache(SOURCE)
    if isinstance(folder, str):
        return folder
    kernel = load_library(folder, "build")
    if isinstance(kernel, str):
        return f"{kernel} (delete {folder} to build it again)"
    return kernel
