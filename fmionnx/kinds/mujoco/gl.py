"""Choose MuJoCo's offscreen OpenGL backend before ``mujoco`` is imported.

MuJoCo binds its GL platform at import time from ``MUJOCO_GL``. An explicit ``MUJOCO_GL`` in
the environment always wins; otherwise the spec's ``gl`` (``egl`` or ``osmesa``) is used, and
``auto`` probes EGL then OSMesa in a short child process (a failed GL initialization can abort
the process that tries it). The probe runs at most once per process, and what it found is
kept for a day (:mod:`.glcache`): a run with a camera does not pay a second for it each time.
"""

from __future__ import annotations

import os
import subprocess
import sys

_PROBE = (
    "import mujoco\n"
    'm = mujoco.MjModel.from_xml_string(\'<mujoco><worldbody><geom size="1"/></worldbody>'
    "</mujoco>')\n"
    "r = mujoco.Renderer(m, 8, 8)\n"
    "d = mujoco.MjData(m); mujoco.mj_forward(m, d); r.update_scene(d); r.render()\n"
)

_chosen: str | None = None
#: What ``auto`` found in this process, by preference (the probe starts a process: once).
_probed: dict[str, str | None] = {}


def _works(backend: str) -> bool:
    env = dict(os.environ, MUJOCO_GL=backend, PYOPENGL_PLATFORM=backend)
    try:
        result = subprocess.run(
            [sys.executable, "-c", _PROBE], env=env, capture_output=True, timeout=60, check=False
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return result.returncode == 0


def backend_for(preference: str = "auto") -> str | None:
    """The backend :func:`choose_gl` would use, without setting it (None: none works).

    For a process that will render under ``--sandbox``, which can start no probe of its own:
    the process that starts it finds the backend here and hands it over in ``MUJOCO_GL``.
    """
    explicit = os.environ.get("MUJOCO_GL")
    if explicit:
        return explicit
    if _chosen is not None:
        return _chosen
    if preference in ("egl", "osmesa"):
        return preference
    if preference not in _probed:
        _probed[preference] = _recalled_or_probed(preference)
    return _probed[preference]


def _recalled_or_probed(preference: str) -> str | None:
    from fmionnx.kinds.mujoco import glcache

    kept = glcache.recall(preference)
    if kept is not None:
        return kept
    found = next((b for b in ("egl", "osmesa") if _works(b)), None)
    if found is not None:
        glcache.remember(preference, found)
    return found


def forget_probe(preference: str = "auto") -> None:
    """A renderer failed to start with the backend found for ``preference``: drop the kept
    answer, so the next process probes again (this one keeps its choice: MuJoCo's is made)."""
    from fmionnx.kinds.mujoco import glcache

    glcache.forget(preference)


def choose_gl(preference: str = "auto") -> str:
    """Set ``MUJOCO_GL`` (and PyOpenGL's platform) for rendering; returns the backend used.

    Raises RuntimeError when ``auto`` finds no working backend.
    """
    global _chosen  # noqa: PLW0603 - one decision per process, like MuJoCo's own
    explicit = os.environ.get("MUJOCO_GL")
    if explicit:
        return explicit
    if _chosen is not None:
        return _chosen
    backend = backend_for(preference)
    if backend is None:
        msg = (
            "no offscreen OpenGL backend works (tried EGL and OSMesa); install "
            "libegl1 + libgl1-mesa-dri, or libosmesa6, or set MUJOCO_GL"
        )
        raise RuntimeError(msg)
    late = "mujoco" in sys.modules
    os.environ["MUJOCO_GL"] = backend
    os.environ.setdefault("PYOPENGL_PLATFORM", backend)
    if late:
        _switch_context(backend)
    _chosen = backend
    return backend


def _switch_context(backend: str) -> None:
    """MuJoCo was imported before a backend was chosen (e.g. by a model reader that loaded a
    scene): point its renderer's GL context class at the chosen backend. ``mujoco.Renderer``
    looks the class up when it is constructed, so this takes effect for new renderers."""
    import importlib

    module = importlib.import_module(f"mujoco.{backend}")
    context = importlib.import_module("mujoco.rendering.classic.gl_context")
    setattr(context, "GLContext", module.GLContext)  # noqa: B010 - a foreign module attribute
