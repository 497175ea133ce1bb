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
it off; where Python has no fork server (Windows), the workers are spawned.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Sequence

#: The environment variable that turns the fork server off (``0``).
SWITCH = "FMIONNX_FORK_WORKERS"
#: What the fork server imports before it forks a worker.
BOOT = "fmionnx.backends.sweep.workerboot"
#: Dask's choice of how the nanny starts a worker.
METHOD_KEY = "distributed.worker.multiprocessing-method"

_started = False


def start(also: Sequence[str] = ()) -> bool:
    """Start the fork server of this process's local workers (once), importing the modules
    ``also`` after :data:`BOOT`'s (what the caller's case runner needs); whether it runs."""
    global _started  # noqa: PLW0603 - one server per process, like Python's own
    from fmionnx.core.switches import switched_off

    if _started:
        return True
    if switched_off(SWITCH) or "forkserver" not in multiprocessing.get_all_start_methods():
        return False
    from multiprocessing import forkserver

    try:
        _own_temporary_folder()
        forkserver.set_forkserver_preload([BOOT, *also])
        forkserver.ensure_running()
    except (OSError, ValueError):  # no process could start: the nanny spawns them as before
        return False
    _started = True
    return True


def _own_temporary_folder() -> None:
    """Give ``multiprocessing``'s temporary folder of this process (where the fork server's
    socket lives) the form of an fmionnx scratch folder, unless it has one already.

    Python makes it as ``pymp-*`` in the temporary directory and removes it at exit; a study
    killed outright (SIGKILL) left it for good. As a scratch folder it is removed at exit as
    well, and otherwise by the next fmionnx process (:mod:`fmionnx.core.scratch`). Python
    keeps its place in the process's ``_config``, where ``get_temp_dir`` finds it."""
    from multiprocessing import process

    from fmionnx.core.scratch import make_scratch

    config = process.current_process()._config  # type: ignore[attr-defined]
    if config.get("tempdir") is None:
        config["tempdir"] = str(make_scratch("mp"))


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
