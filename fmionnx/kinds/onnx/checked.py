"""Which ONNX models passed the run-time check already (``<cache>/onnx-checked``).

Before onnxruntime loads a model, the runner checks it again (:mod:`.runner`): it may have
changed since it was compiled, and what it stores and computes must stay within the limits
(:mod:`.sizes`, :mod:`.external`). That needs the ``onnx`` package and ONNX shape
inference: about 0.2 s of every run with a model, and of every worker of a study, for the
same bytes each time.

The check's verdict depends only on the model's bytes, the limits in force and the checking
code, as long as the model keeps no tensor in an external file (whose files could change
without the model's bytes changing). So a model without external data that passed is
remembered under a key of exactly those: the sha256 of its bytes, the limits' values and
fmionnx's version. The runner then reads the bytes once, hashes them, and when the key is
remembered hands onnxruntime *those bytes* (never the path again, so what was checked is
what runs) without importing ``onnx``. A model with external data is checked on every run,
as before. ``FMIONNX_ONNX_CHECKED=0`` turns the remembering off.

A verdict lets a model skip a check, so it is kept as the compile cache keeps its entries
(:mod:`fmionnx.core.private`): in a folder owned by this user that nobody else may write,
never read through a link, and signed with this user's key; a verdict someone else wrote, or
one that does not check out, is ignored and the model is checked.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
from pathlib import Path

from fmionnx.core.cachedir import cache_folder
from fmionnx.core.private import (
    NotPrivateError,
    check_private_folder,
    read_private,
    signature,
    signed_by,
    user_key,
    write_private,
)
from fmionnx.core.resources import ARRAY_ELEMENTS, MODEL_ELEMENTS, MODEL_FILE_BYTES
from fmionnx.core.switches import switched_off
from fmionnx.kinds.cache import file_identity

#: The environment variable that turns the remembering off (``0``).
SWITCH = "FMIONNX_ONNX_CHECKED"
#: The folder's name in the cache.
FOLDER = "onnx-checked"
#: The limits the check applies (:mod:`.sizes`): their values are part of the key.
_LIMITS = (ARRAY_ELEMENTS, MODEL_ELEMENTS, MODEL_FILE_BYTES)


def enabled() -> bool:
    """Whether verdicts are remembered (``FMIONNX_ONNX_CHECKED`` unset or not a "no")."""
    return not switched_off(SWITCH)


def key(data: bytes) -> str:
    """What a verdict on the model of bytes ``data`` is about: those bytes, under the limits
    in force, checked by this code (fmionnx's checking modules and the installed ``onnx``)."""
    limits = [f"{limit.variable}={limit.value()}" for limit in _LIMITS]
    parts = [hashlib.sha256(data).hexdigest(), *limits, *_checker_stamps()]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


@functools.cache
def _checker_stamps() -> tuple[str, ...]:
    """The checking code: the sources of the modules that check, and ``onnx``'s installed
    package (found without importing it: the import is what a verdict saves). Read once per
    process, as the code it describes is loaded once."""
    import importlib.util

    from fmionnx.core import resources
    from fmionnx.kinds.onnx import external, interface, sizes

    stamps = []
    for module in (external, interface, sizes, resources):
        source = Path(str(module.__file__))
        stamps.append(hashlib.sha256(source.read_bytes()).hexdigest())
    with contextlib.suppress(ImportError, ValueError, OSError):
        spec = importlib.util.find_spec("onnx")
        if spec is not None and spec.origin is not None:
            stamps.append(f"onnx:{file_identity(Path(spec.origin))}")
    return tuple(stamps)


def entry(data: bytes) -> Path:
    """The cache file that holds the verdict on the model of bytes ``data``."""
    return _entry(key(data))


def _entry(verdict_key: str) -> Path:
    return cache_folder(FOLDER) / verdict_key[:40]


def passed(data: bytes) -> bool:
    """Whether the model of bytes ``data`` is remembered to have passed: a private, signed
    verdict of this user for exactly this key."""
    if not enabled():
        return False
    try:
        verdict_key = key(data)
        path = _entry(verdict_key)
        check_private_folder(path.parent)
        claimed = read_private(path, 64).decode("ascii", "replace")
        return signed_by(user_key(path.parent, make=False), verdict_key.encode(), claimed)
    except (OSError, NotPrivateError):
        return False


def remember(data: bytes) -> None:
    """Remember that the model of bytes ``data`` (without external data) passed; a cache that
    cannot be written (or is not this user's alone) is no error: the next run checks again."""
    if not enabled():
        return
    with contextlib.suppress(OSError, NotPrivateError):
        verdict_key = key(data)
        path = _entry(verdict_key)
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        check_private_folder(path.parent)
        verdict = signature(user_key(path.parent, make=True), verdict_key.encode())
        write_private(path, verdict.encode())
