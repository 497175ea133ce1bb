"""What the fork server of a local cluster's workers runs before it forks one (its preload,
:mod:`.workerfork`); imported anywhere else (not by the fork server's start), it does nothing.

In this order, because a worker is a copy of the server:

1. SIGINT is ignored. A terminal's Ctrl-C goes to the driver and its workers alike, and the
   driver alone decides (the finished cases kept, the cluster closed in order). The fork
   server hands its children the handlers it found when it started, so a forked worker
   ignores SIGINT from its first instruction (a spawned one does from
   :mod:`fmionnx.spawned`).
2. The environment Dask's nanny sets before it spawns a worker (``pre-spawn-environ``: one
   OpenMP, MKL and OpenBLAS thread by default, a fixed hash seed) is the server's from its
   start: the command starts it with those variables (:func:`.workerfork.start`), and a
   server ``multiprocessing`` starts again later is started by a nanny, which has set them.
   The libraries that read them do so when they are loaded, next.
3. Dask's ``distributed`` and fmionnx's case modules are imported (the caller's case runner
   after them, :func:`.workerfork.start`): what every worker would import before its first
   case, the runtime and every kind's module included, and what an isolated child needs
   (fmpy's runner, the native kernel). MuJoCo, PyOpenGL and onnxruntime are not: MuJoCo and
   PyOpenGL choose their GL platform from the environment when imported (``MUJOCO_GL``,
   ``PYOPENGL_PLATFORM``), which a worker sets (:mod:`fmionnx.kinds.mujoco.gl`), and
   onnxruntime starts a thread when imported, which a fork would not copy.
4. Each worker, as ``multiprocessing`` starts it and before Dask starts its threads, forks
   its isolated children's zygote (:func:`_fork_zygote`), warm from the server's imports.
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing.util
import os
import signal
import sys

from fmionnx.runtime import lifetime  # standard library only: used at a worker's fork


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
    whose workers end with it (:func:`_worker_dies_with_server`) and that ends at once when
    the command has (:func:`_end_at_once`)."""
    global _server  # noqa: PLW0603 - set once, in the server
    _server = os.getpid()
    atexit.register(_end_at_once)
    os.register_at_fork(before=_note_forker, after_in_child=_worker_dies_with_server)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import distributed  # noqa: F401

    import fmionnx.backends.sweep.case
    import fmionnx.backends.sweep.models
    import fmionnx.backends.sweep.pinning
    import fmionnx.backends.sweep.quiet
    import fmionnx.core.xmlsafe
    import fmionnx.runtime.isolated.proxy
    import fmionnx.runtime.master  # noqa: F401
    from fmionnx.kinds.registry import COMPONENT_KINDS
    from fmionnx.runtime.isolated import zygote

    for _ in COMPONENT_KINDS.values():  # each kind's module, not its library
        pass
    zygote.warm_up()  # what an isolated child needs: fmpy's runner, the native kernel
    multiprocessing.util.register_after_fork(_WORKER_START, _fork_zygote)


#: The fork server's process id (in the server and its workers), once :func:`boot` ran.
_server: int | None = None
#: Whether the process forking now is the server (set in it before each fork, so a worker
#: learns it was forked by the server, not by a worker of its own forking later).
_forked_by_server = False


def booted() -> bool:
    """Whether this process is the fork server or was forked by it (:func:`boot` ran)."""
    return _server is not None


def _note_forker() -> None:
    global _forked_by_server  # noqa: PLW0603 - read by the child, in its copy
    _forked_by_server = os.getpid() == _server


def _worker_dies_with_server() -> None:
    """In a worker, from its first instruction: die when the server dies (SIGKILL).

    A worker is the server's child, and the nanny learns that its worker ended from the
    server. Killed (an out-of-memory killer, a user), the server told every nanny that its
    worker had ended while the workers ran on, beside the new ones the nannies started. Now
    the workers end with the server, the nannies start new ones from a new server
    (``multiprocessing`` starts it again) and the study runs their cases again, as after any
    worker's death."""
    global _forked_by_server  # noqa: PLW0603 - this process's copy
    if not _forked_by_server:
        return
    _forked_by_server = False
    lifetime.die_with_parent()
    if os.getppid() != _server:  # the server died before the request took: end now
        os._exit(1)


class _WorkerStart:
    """The key of :func:`_fork_zygote` in ``multiprocessing``'s after-fork registry (a
    weakly referenced object, kept alive here)."""


_WORKER_START = _WorkerStart()


def _fork_zygote(_: object) -> None:
    """In a worker as ``multiprocessing`` starts it (still single-threaded, before Dask's
    threads): fork its isolated children's zygote from it, warm at once.

    A zygote started as a new interpreter imports for about 0.45 s of CPU, in every worker
    of every study whose FMUs are isolated (16 workers: 16 starts); a fork of the worker,
    which has everything imported from the server, costs a few milliseconds. A worker whose
    cases isolate nothing keeps an idle zygote, which ends with it."""
    if _server is None or os.getpid() == _server or os.getppid() != _server:
        return
    from fmionnx.runtime.isolated.launcher import fork_zygote

    fork_zygote()


def _end_at_once() -> None:
    """End the server without tearing down its interpreter (Dask, numpy, fmionnx's modules),
    from an exit hook (before the teardown): torn down, the server held the command's
    standard output and error 0.1-0.15 s after the command itself ended, and a caller reading
    them (a script, CI) waited. Its workers never run it: a process ``multiprocessing``
    starts ends with ``os._exit``."""
    with contextlib.suppress(OSError, ValueError):
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(0)


if _in_fork_server_start():
    boot()
