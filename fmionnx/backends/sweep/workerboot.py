"""What the fork server of a local cluster's workers runs before it forks one (its preload,
:mod:`.workerfork`); imported anywhere else (not by the fork server's start), it does nothing.

In this order, because a worker is a copy of the server:

1. SIGINT is ignored. A terminal's Ctrl-C goes to the driver and its workers alike, and the
   driver alone decides (the finished cases kept, the cluster closed in order). The fork
   server hands its children the handlers it found when it started, so a forked worker
   ignores SIGINT from its first instruction (a spawned one does from
   :mod:`fmionnx.spawned`).
2. The environment Dask's nanny sets before it spawns a worker (``pre-spawn-environ``: one
   OpenMP, MKL and OpenBLAS thread by default) is set here, from Dask's defaults, the user's
   Dask configuration and :data:`.daskconfig.LOCAL_CONFIG`, as the nanny computes it: those
   libraries read it once, when they are loaded, and they are loaded next. The nanny sets it
   in the driver only, which a forked worker no longer inherits.
3. Dask's ``distributed`` and fmionnx's case modules are imported (the caller's case runner
   after them, :func:`.workerfork.start`): what every worker would import before its first
   case, the runtime and every kind's module included. The models' libraries (MuJoCo,
   PyOpenGL, onnxruntime, fmpy) are not: MuJoCo and PyOpenGL choose their GL platform from
   the environment when imported (``MUJOCO_GL``, ``PYOPENGL_PLATFORM``), which a worker sets
   (:mod:`fmionnx.kinds.mujoco.gl`), and onnxruntime starts a thread when imported, which a
   fork would not copy.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import sys

#: Dask's configuration key of the variables set before a worker starts.
PRE_SPAWN = "distributed.nanny.pre-spawn-environ"


def pre_spawn_environment() -> dict[str, str]:
    """The variables Dask's nanny would set for a local cluster's worker, without importing
    ``distributed`` (which loads numpy, and with it OpenBLAS): its defaults are read from its
    own file, as its configuration module does; a variable already set keeps its value."""
    import importlib.util
    from pathlib import Path

    import dask.config

    from fmionnx.backends.sweep.daskconfig import LOCAL_CONFIG

    spec = importlib.util.find_spec("distributed")
    if spec is not None and spec.origin is not None:
        defaults = Path(spec.origin).with_name("distributed.yaml")
        for found in dask.config.collect_yaml([str(defaults)]):
            dask.config.update_defaults(found)
    ours = {key: value for key, value in LOCAL_CONFIG.items() if key.startswith(PRE_SPAWN)}
    with dask.config.set(ours):  # undone on leaving, in the dictionary ``get`` returns too
        wanted = dict(dask.config.get(PRE_SPAWN, default={}) or {})
    return {
        key: os.environ.get(key, str(value)) for key, value in wanted.items() if value is not None
    }


def _in_fork_server_start() -> bool:
    """Whether this import is the fork server's preload: its ``main`` is a caller."""
    from multiprocessing import forkserver

    frame = sys._getframe(1)
    while frame is not None:
        code = frame.f_code
        if code.co_name == "main" and code.co_filename == forkserver.__file__:
            return True
        frame = frame.f_back  # type: ignore[assignment]
    return False


def boot() -> None:
    """Make this process what a forked worker starts from (the steps above), and a server
    that ends at once when the command has (:func:`_end_at_once`)."""
    atexit.register(_end_at_once)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.update(pre_spawn_environment())
    import distributed  # noqa: F401

    import fmionnx.backends.sweep.case
    import fmionnx.backends.sweep.models
    import fmionnx.backends.sweep.pinning
    import fmionnx.backends.sweep.quiet
    import fmionnx.core.xmlsafe
    import fmionnx.runtime.isolated.proxy
    import fmionnx.runtime.master  # noqa: F401
    from fmionnx.kinds.registry import COMPONENT_KINDS

    for _ in COMPONENT_KINDS.values():  # each kind's module, not its library
        pass


def _end_at_once() -> None:
    """End the server without tearing down its interpreter (Dask, numpy, fmionnx's modules):
    0.1-0.15 s after the command itself ended, during which the server still held the
    command's standard output and error, and a caller reading them (a script, CI) waited.
    Its workers never run it: a process ``multiprocessing`` starts ends with ``os._exit``."""
    with contextlib.suppress(OSError, ValueError):
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(0)


if _in_fork_server_start():
    boot()
