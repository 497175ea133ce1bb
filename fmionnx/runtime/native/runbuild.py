"""``FMIONNX_NATIVE=build``: compile the kernel at run time into a per-user cache (opt-in).

Normally the kernel is the library built when fmionnx was installed. This path is for a
source tree used without installing it, or to try another compiler: the system C compiler
(``$FMIONNX_CC``, else ``$CC``, else ``cc``) builds it with the flags of the installed build
(:data:`.manifest.COMPILE_FLAGS`) into ``$FMIONNX_CACHE/native/<key>/`` (else
``$XDG_CACHE_HOME`` or ``~/.cache`` ``/fmionnx/native/<key>/``), the key a hash of the source,
flags and compiler. The library and its build manifest are written into a fresh folder that
is renamed into place, so concurrent runs never see a half-written one; the caller loads it
only after checking it against that manifest (:func:`.kernel.load_library`). Nothing here
raises: a missing compiler or a failed build gives a reason.
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
from pathlib import Path

from fmionnx.core.cachedir import cache_folder
from fmionnx.runtime.native.manifest import COMPILE_FLAGS, LIBRARY_NAME, write_manifest

#: Environment variable naming the C compiler (checked before ``CC``).
COMPILER_ENV = "FMIONNX_CC"

#: Flags that make a shared library of the one C file.
SHARED_FLAGS = ("-shared", "-fPIC")


def compiler() -> str:
    """The compiler command name the environment asks for."""
    return os.environ.get(COMPILER_ENV) or os.environ.get("CC") or "cc"


def cache_root() -> Path:
    """``$FMIONNX_CACHE/native``, else the XDG cache folder (as the SSP cache does)."""
    return cache_folder("native")


def _key(source: bytes, command: str) -> str:
    digest = hashlib.sha256(source)
    for part in (*COMPILE_FLAGS, *SHARED_FLAGS, command, platform.machine(), platform.system()):
        digest.update(b"\0" + part.encode())
    return digest.hexdigest()[:16]


def build_in_cache(source: Path) -> Path | str:
    """The cache folder holding ``source``'s library and manifest, built now if absent;
    else why it could not be built. The folder's content is not checked here."""
    command = compiler()
    try:
        folder = cache_root() / _key(source.read_bytes(), command)
    except OSError as exc:
        return f"kernel source unreadable: {exc}"
    if folder.is_dir():
        return folder
    program = shutil.which(command)
    if program is None:
        return f"no C compiler: `{command}` not found (set {COMPILER_ENV} or CC)"
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        partial = Path(tempfile.mkdtemp(prefix=".build-", dir=folder.parent))
    except OSError as exc:
        return f"cache folder not writable: {exc}"
    try:
        problem = _compile(program, command, source, partial / LIBRARY_NAME)
        if problem is not None:
            return problem
        write_manifest(partial, source, "FMIONNX_NATIVE=build", command)
        partial.rename(folder)
    except OSError as exc:
        if not folder.is_dir():  # else a concurrent run renamed its build first: use that
            return f"writing the kernel into the cache failed: {exc}"
    finally:
        shutil.rmtree(partial, ignore_errors=True)
    return folder


def _compile(program: str, command: str, source: Path, library: Path) -> str | None:
    """Compile ``source`` into ``library``; None on success, else the reason it failed."""
    try:
        result = subprocess.run(
            [program, *COMPILE_FLAGS, *SHARED_FLAGS, "-o", str(library), str(source), "-lm"],
            capture_output=True,
            text=True,
            check=False,
            timeout=120,
        )
    except (OSError, subprocess.SubprocessError) as exc:
        return f"`{command}` could not run: {exc}"
    if result.returncode != 0:
        log = (result.stderr or result.stdout).strip().splitlines()
        return f"`{command}` failed (exit {result.returncode}): " + " | ".join(log[-3:])
    return None
