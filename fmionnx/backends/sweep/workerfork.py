"""A local cluster's workers forked from a server that has imported what they need, started
with the ``fmionnx sweep`` command rather than when its cluster starts.

Dask's nanny starts each worker as a new interpreter (``spawn``) once the driver has imported
Dask's ``distributed`` and started the scheduler: each worker then imports ``distributed``
(0.45 s of CPU on the 2-core machine) and fmionnx's case modules before its first case, and
on 2 cores the driver's and the workers' imports wait for each other. Here the command starts
Python's fork server at once, with :mod:`.workerboot` as its preload: it imports them while
the driver compiles the study and imports ``distributed`` itself, and each worker (a restarted
one too) is a fork of it, ready in milliseconds. The nanny is the same, and so is what it
does: the worker's configuration, the restarts, the ``distributed.nanny.environ`` variables.

Only a process that is the command and nothing else starts the server
(:func:`fmionnx.cli.whole_process`): the server keeps the environment it was started with
for every worker it forks, while a program calling :func:`fmionnx.sweep` may change its
environment between two studies, which spawned workers see. ``FMIONNX_FORK_WORKERS=0`` turns
it off; where Python has no fork server (Windows) or the server cannot start, the workers are
spawned (said at debug level, logger ``fmionnx.backends.sweep.workerfork``). The server's
workers end with it (:mod:`.workerboot`): killed, it is started again by the next nanny that
starts a worker, and the study runs the cases of the workers it lost again.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
from collections.abc import Iterator, Sequence

#: The environment variable that turns the fork server off (``0``).
SWITCH = "FMIONNX_FORK_WORKERS"
#: What the fork server imports before it forks a worker.
BOOT = "fmionnx.backends.sweep.workerboot"
#: Dask's choice of how the nanny starts a worker.
METHOD_KEY = "distributed.worker.multiprocessing-method"
#: The hash seed Dask's nanny gives its workers unless the configuration names one (every
#: worker of a cluster hashes alike).
HASH_SEED, DASK_HASH_SEED = "PYTHONHASHSEED", "6640"
#: A Unix socket's path, in bytes with its final zero (Linux); and the bytes the fork
#: server's socket adds to its folder's (``/listener-`` and 8 characters).
SOCKET_PATH_BYTES, SOCKET_NAME_BYTES = 108, 19

LOG = logging.getLogger(__name__)

_started = False


def start(also: Sequence[str] = ()) -> bool:
    """Start the fork server of this process's local workers (once), importing the modules
    ``also`` after :data:`BOOT`'s (what the caller's case runner needs); whether it runs.

    The server starts with the variables Dask's nanny sets before it starts a worker
    (:func:`pre_spawn_environment`): they are set in this process's environment only while
    the server starts, as the nanny sets them while it starts a worker."""
    global _started  # noqa: PLW0603 - one server per process, like Python's own
    from fmionnx.core.switches import switched_off

    if _started:
        return True
    if switched_off(SWITCH):
        LOG.debug("local workers spawned: %s=0", SWITCH)
        return False
    if "forkserver" not in multiprocessing.get_all_start_methods():
        LOG.debug("local workers spawned: no fork server on this platform")
        return False
    from multiprocessing import forkserver

    from fmionnx.core.environ import variables_set

    try:
        _own_temporary_folder()
        forkserver.set_forkserver_preload([BOOT, *also])
        with variables_set(pre_spawn_environment()), _interrupts_ignored():
            forkserver.ensure_running()
    except (OSError, ValueError) as exc:  # no process could start: the nanny spawns them
        LOG.debug("local workers spawned: the fork server could not start (%s)", exc)
        return False
    _started = True
    return True


@contextlib.contextmanager
def _interrupts_ignored() -> Iterator[None]:
    """SIGINT ignored while the server is started: an ignored signal stays ignored in the
    program a process starts, so the server ignores a terminal's Ctrl-C from its first
    instruction. Its preload ignores it too (:mod:`.workerboot`), but only once its imports
    got there: a Ctrl-C in the first half second printed the server's traceback. A Ctrl-C in
    the few milliseconds of the start itself is lost to the command (pressed again, it
    stops it)."""
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: the preload ignores it, as before
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def pre_spawn_environment() -> dict[str, str]:
    """The variables Dask's nanny sets before it starts a local cluster's worker, as it
    computes them (``pre-spawn-environ`` from Dask's defaults, the user's Dask configuration
    and :data:`.daskconfig.LOCAL_CONFIG`, a variable already set keeping its value, and a
    fixed hash seed unless one is given), without importing ``distributed``: its defaults
    are read from its own file, as its configuration module reads them."""
    import importlib.util
    from pathlib import Path

    import dask.config

    from fmionnx.backends.sweep.daskconfig import LOCAL_CONFIG, PRE_SPAWN

    spec = importlib.util.find_spec("distributed")
    if spec is not None and spec.origin is not None:
        defaults = Path(spec.origin).with_name("distributed.yaml")
        for read in dask.config.collect_yaml([str(defaults)]):
            dask.config.update_defaults(read)
    ours = {key: value for key, value in LOCAL_CONFIG.items() if key.startswith(PRE_SPAWN)}
    with dask.config.set(ours):  # undone on leaving, in the dictionary ``get`` returns too
        wanted = dict(dask.config.get(PRE_SPAWN, default={}) or {})
    found = {
        key: os.environ.get(key, str(value)) for key, value in wanted.items() if value is not None
    }
    if found.get(HASH_SEED) in (None, "0"):
        found[HASH_SEED] = DASK_HASH_SEED
    return found


def _own_temporary_folder() -> None:
    """Give ``multiprocessing``'s temporary folder of this process (where the fork server's
    socket lives) the form of an fmionnx scratch folder, unless it has one already.

    Python makes it as ``pymp-*`` in the temporary directory and removes it at exit; a study
    killed outright (SIGKILL) left it for good. As a scratch folder it is removed at exit as
    well, and otherwise by the next fmionnx process (:mod:`fmionnx.core.scratch`). Python
    keeps its place in the process's ``_config``, where ``get_temp_dir`` finds it. Where the
    scratch folder's path leaves the socket's too long (a ``TMPDIR`` of over about 60
    characters), Python's shorter ``pymp-*`` folder is used, as without fmionnx."""
    from multiprocessing import process

    from fmionnx.core.scratch import make_scratch, remove_scratch

    config = process.current_process()._config  # type: ignore[attr-defined]
    if config.get("tempdir") is not None:
        return
    folder = make_scratch("mp")
    if len(os.fsencode(folder)) + SOCKET_NAME_BYTES > SOCKET_PATH_BYTES:
        remove_scratch(folder)  # too long a path for the socket: Python's shorter one
        LOG.debug("the fork server's socket in Python's temporary folder: %s is long", folder)
        return
    config["tempdir"] = str(folder)


def fork_local_workers() -> None:
    """Have the nannies of this process's local clusters fork their workers from the server,
    when it runs: the first ones and those that replace a worker that died. A process-wide
    Dask setting, because a nanny reads it each time it starts a worker; the server runs only
    in a process that is the command (see the module).

    Dask imports, on the first fork of a process, each of its optional libraries that is
    installed (pandas, numpy, lz4) into the driver, to name them as the fork server's preload:
    pandas alone took 0.45 s on the way to the first worker, for a server running already
    with its own preload. Dask keeps in ``_forkserver_preload_set`` that it did this; set here,
    Dask leaves the preload as it is. A Dask version without that flag only costs the import.
    """
    if not _started:
        return
    import dask
    import distributed.utils

    if hasattr(distributed.utils, "_forkserver_preload_set"):
        distributed.utils._forkserver_preload_set = True
    dask.config.set({METHOD_KEY: "forkserver"})
