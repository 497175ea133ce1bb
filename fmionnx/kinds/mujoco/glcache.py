"""What the OpenGL probe found on this machine, kept for a day (``<cache>/gl``).

Finding MuJoCo's offscreen backend (:mod:`.gl`) starts a Python process that imports MuJoCo
and renders one frame: about a second, which every run with a camera paid before its first
step, and every worker of a study once more. The answer depends on the machine, not on the
run, so it is kept, under a key made of everything that decides it and is cheap to read:

* the interpreter and MuJoCo's installed files (another environment, another MuJoCo);
* the environment variables the GL libraries and MuJoCo read (display, vendor selection,
  software rendering, the library path, the GPU chosen);
* the system's library cache (``/etc/ld.so.cache``, rewritten whenever a system library is
  installed or removed), the GL vendor lists and the GPU device nodes.

Only a backend that worked is kept: a machine where none works probes again on every run,
so installing a library helps at once. An entry is trusted for :data:`MAX_AGE` seconds,
which bounds the harm of a change the key does not see; a renderer that fails to start
after a kept answer also drops it (:func:`forget`), so the next run probes again.
``FMIONNX_GL_CACHE=0`` turns the keeping off; an explicit ``MUJOCO_GL`` skips the probe and
this cache altogether.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
import time
from pathlib import Path

from fmionnx.core.cachedir import cache_folder
from fmionnx.core.switches import switched_off

#: The environment variable that turns the keeping off (``0``).
SWITCH = "FMIONNX_GL_CACHE"
#: Seconds a kept answer is trusted.
MAX_AGE = 24 * 3600
#: Environment variables that change which GL backend works.
_ENVIRONMENT = (
    "DISPLAY",
    "WAYLAND_DISPLAY",
    "EGL_PLATFORM",
    "__EGL_VENDOR_LIBRARY_DIRS",
    "__EGL_VENDOR_LIBRARY_FILENAMES",
    "__GLX_VENDOR_LIBRARY_NAME",
    "LIBGL_ALWAYS_SOFTWARE",
    "GALLIUM_DRIVER",
    "MESA_LOADER_DRIVER_OVERRIDE",
    "LD_LIBRARY_PATH",
    "LD_PRELOAD",
    "CUDA_VISIBLE_DEVICES",
    "MUJOCO_EGL_DEVICE_ID",
    "PYOPENGL_PLATFORM",
)
#: Files and folders whose change means the system's GL libraries or devices changed.
_SYSTEM = (
    "/etc/ld.so.cache",
    "/usr/share/glvnd/egl_vendor.d",
    "/etc/glvnd/egl_vendor.d",
    "/dev/dri",
)
#: Backend names an entry may hold (anything else in the file is ignored).
_BACKENDS = frozenset({"egl", "osmesa"})


def enabled() -> bool:
    """Whether answers are kept (``FMIONNX_GL_CACHE`` unset or not a "no")."""
    return not switched_off(SWITCH)


def _stamp(path: str) -> str:
    try:
        info = Path(path).stat()
    except OSError:
        return f"{path}:-"
    return f"{path}:{info.st_ino}:{info.st_size}:{info.st_mtime_ns}"


def _mujoco_stamp() -> str:
    """MuJoCo's installed package, found without importing it (the import is what a kept
    answer saves)."""
    import importlib.util

    with contextlib.suppress(ImportError, ValueError):
        spec = importlib.util.find_spec("mujoco")
        if spec is not None and spec.origin is not None:
            return _stamp(spec.origin)
    return "mujoco:-"


def _setting(name: str) -> str:
    """An environment variable's value; a search path as its set of folders (the ROS 2 wheels'
    start-up sets ``LD_LIBRARY_PATH`` in another order in each process)."""
    value = os.environ.get(name, "")
    if name == "LD_LIBRARY_PATH":
        return os.pathsep.join(sorted(set(value.split(os.pathsep))))
    return value


def entry(preference: str) -> Path:
    """The cache file that holds the answer for ``preference`` here."""
    parts = [
        sys.executable,
        sys.version,
        preference,
        _mujoco_stamp(),
        *(f"{name}={_setting(name)}" for name in _ENVIRONMENT),
        *(_stamp(path) for path in _SYSTEM),
    ]
    key = hashlib.sha256("\0".join(parts).encode("utf-8", "surrogateescape")).hexdigest()
    return cache_folder("gl") / f"{key[:32]}.txt"


def recall(preference: str) -> str | None:
    """The backend kept for ``preference`` on this machine, or None (none kept, too old,
    unreadable, or keeping is off)."""
    if not enabled():
        return None
    path = entry(preference)
    try:
        if time.time() - path.stat().st_mtime > MAX_AGE:
            return None
        text = path.read_text("ascii", errors="replace").strip()
    except OSError:
        return None
    return text if text in _BACKENDS else None


def remember(preference: str, backend: str) -> None:
    """Keep ``backend`` as the answer for ``preference`` (atomically; a cache that cannot be
    written is no error: the next run probes again). Entries past :data:`MAX_AGE` go."""
    if not enabled() or backend not in _BACKENDS:
        return
    path = entry(preference)
    scratch = path.with_name(f".{path.name}.{os.getpid()}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        scratch.write_text(backend + "\n", "ascii")
        scratch.replace(path)
    except OSError:
        with contextlib.suppress(OSError):
            scratch.unlink()
        return
    _drop_old(path.parent)


def _drop_old(folder: Path) -> None:
    """Remove entries (and a dead writer's scratch files) older than :data:`MAX_AGE`."""
    now = time.time()
    with contextlib.suppress(OSError):
        for old in folder.iterdir():
            with contextlib.suppress(OSError):
                if now - old.lstat().st_mtime > MAX_AGE:
                    old.unlink()


def forget(preference: str) -> None:
    """Drop the answer kept for ``preference`` (a renderer failed to start with it)."""
    with contextlib.suppress(OSError):
        entry(preference).unlink()
