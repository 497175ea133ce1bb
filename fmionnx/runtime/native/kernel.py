"""Compile ``fmi2_group.c`` once per machine and load it with ctypes.

The kernel is built at first use with the system C compiler (``$FMIONNX_CC``, else ``$CC``,
else ``cc``) into a per-user cache folder named after a hash of the source, the flags and the
compiler (``$FMIONNX_CACHE/native/<hash>/``, else ``$XDG_CACHE_HOME`` or ``~/.cache``
``/fmionnx/native/<hash>/``). The library is written to a temporary name and renamed into
place, so concurrent runs never load a half-written file. Nothing here raises: a missing
compiler or a failed build gives a reason, and the master keeps its Python path.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

SOURCE = Path(__file__).with_name("fmi2_group.c")

#: ``-ffp-contract=off``: ``factor*x + offset`` must round twice, as numpy does.
FLAGS = ("-O2", "-shared", "-fPIC", "-std=c99", "-ffp-contract=off")

#: Environment variable naming the C compiler (checked before ``CC``).
COMPILER_ENV = "FMIONNX_CC"


class Group(ctypes.Structure):
    """``fx_group`` of ``fmi2_group.c`` (field order and types must match)."""

    _fields_ = (
        ("n_members", ctypes.c_size_t),
        ("members", ctypes.c_void_p),
        ("transfers", ctypes.c_void_p),
        ("failed_member", ctypes.c_size_t),
        ("failed_transfer", ctypes.c_size_t),
        ("failed_status", ctypes.c_int),
    )


class Member(ctypes.Structure):
    """``fx_member`` of ``fmi2_group.c``."""

    _fields_ = (
        ("instance", ctypes.c_void_p),
        ("set_real", ctypes.c_void_p),
        ("do_step", ctypes.c_void_p),
        ("get_real", ctypes.c_void_p),
        ("in_vrs", ctypes.c_void_p),
        ("n_in", ctypes.c_size_t),
        ("in_values", ctypes.c_void_p),
        ("out_vrs", ctypes.c_void_p),
        ("n_out", ctypes.c_size_t),
        ("out_values", ctypes.c_void_p),
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
    )


#: Return codes of ``fx_group_step``.
OK, NAN, SET, DO_STEP, GET = 0, 1, 2, 3, 4


@dataclass(frozen=True)
class Kernel:
    """The loaded library's step function: ``step(byref(group), t, h) -> code``."""

    path: Path
    step: Callable[..., int]


def compiler() -> str:
    """The compiler command name the environment asks for."""
    return os.environ.get(COMPILER_ENV) or os.environ.get("CC") or "cc"


def cache_root() -> Path:
    """``$FMIONNX_CACHE/native``, else the XDG cache folder (as the SSP cache does)."""
    explicit = os.environ.get("FMIONNX_CACHE")
    if explicit:
        return Path(explicit).expanduser() / "native"
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "fmionnx" / "native"


def _key(source: bytes, command: str) -> str:
    digest = hashlib.sha256(source)
    for part in (*FLAGS, command, platform.machine(), platform.system()):
        digest.update(b"\0" + part.encode())
    return digest.hexdigest()[:16]


#: Libraries loaded in this process, by path (a library is never loaded twice).
_LOADED: dict[Path, Kernel] = {}


def load_kernel() -> Kernel | str:
    """The kernel, compiled now if the cache lacks it; else why it is not available."""
    command = compiler()
    try:
        source = SOURCE.read_bytes()
    except OSError as exc:
        return f"kernel source unreadable: {exc}"
    library = cache_root() / _key(source, command) / "fmi2_group.so"
    if library in _LOADED:
        return _LOADED[library]
    if not library.is_file():
        problem = _compile(command, library)
        if problem is not None:
            return problem
    try:
        dll = ctypes.CDLL(str(library))
    except OSError as exc:
        return f"loading {library.name} failed: {exc}"
    step = dll.fx_group_step
    step.argtypes = (ctypes.c_void_p, ctypes.c_double, ctypes.c_double)
    step.restype = ctypes.c_int
    kernel = Kernel(library, step)
    _LOADED[library] = kernel
    return kernel


def _compile(command: str, library: Path) -> str | None:
    """Build ``library`` atomically; None on success, else the reason it failed."""
    program = shutil.which(command)
    if program is None:
        return f"no C compiler: `{command}` not found (set {COMPILER_ENV} or CC)"
    try:
        library.parent.mkdir(parents=True, exist_ok=True)
        fd, partial = tempfile.mkstemp(prefix=".build-", suffix=".so", dir=library.parent)
        os.close(fd)
    except OSError as exc:
        return f"cache folder not writable: {exc}"
    try:
        result = subprocess.run(
            [program, *FLAGS, "-o", partial, str(SOURCE), "-lm"],
            capture_output=True,
            text=True,
            check=False,
            timeout=120,
        )
        if result.returncode != 0:
            log = (result.stderr or result.stdout).strip().splitlines()
            return f"`{command}` failed (exit {result.returncode}): " + " | ".join(log[-3:])
        Path(partial).replace(library)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"`{command}` could not run: {exc}"
    finally:
        Path(partial).unlink(missing_ok=True)
    return None
