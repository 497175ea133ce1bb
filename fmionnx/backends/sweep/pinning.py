"""A local cluster's workers each on cores of their own (a Dask worker preload).

A worker runs one case at a time on one core (:func:`~.case.one_core_per_case`), but the
operating system is free to move it, and an isolated model's child with it, between the
cores: a step handed to a child woken on the core where another worker's case runs waits
for that case to be preempted, and a process that moves loses its caches. Where the local
cluster has several workers and no more than the cores this process may use, worker *i*
(Dask names a local cluster's workers 0, 1, ...) is pinned to the *i*-th share of them (one
core each when there are as many workers as cores), every thread of it, and what it starts
(the zygote, the isolated children, the renderer's threads) inherits its share. On the
2-core machine a reference case with FMUs isolated took 10 % less time in a study of 2
workers, the same case not isolated as long as before (docs/performance.md). A master whose
process is confined to one core does not spin on its children's replies either: they can
only run on that core once it waits (:func:`fmionnx.runtime.isolated.proxy.supervisor_spin_ns`).

An existing cluster (``--scheduler``) is not ours to pin: its workers keep the placement
they were given. ``FMIONNX_PIN_WORKERS=0`` leaves a local cluster's to the system too.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Any

#: Dask's configuration key holding the cores the workers are pinned to (set for the local
#: cluster by :mod:`.engine`; absent: no pinning).
CORES_KEY = "fmionnx.worker-cores"
#: The environment variable that leaves the workers' placement to the system (``0``).
SWITCH = "FMIONNX_PIN_WORKERS"


def cores_for(workers: int) -> list[list[int]] | None:
    """The cores of each worker of a local cluster of ``workers``: this process's cores cut
    into that many shares, as equal as they come (one core each when there are as many
    workers as cores; 3 workers on 8 cores get 3, 3 and 2). None for one worker (all cores
    are its own), more workers than cores (the system then places them), no affinity here,
    or ``FMIONNX_PIN_WORKERS=0``."""
    from fmionnx.core.cores import usable_core_ids
    from fmionnx.core.switches import switched_off

    cores = None if switched_off(SWITCH) else usable_core_ids()
    if cores is None or not 1 < workers <= len(cores):
        return None
    share, extra = divmod(len(cores), workers)
    bounds = [i * share + min(i, extra) for i in range(workers + 1)]
    return [cores[bounds[i] : bounds[i + 1]] for i in range(workers)]


def pin_process(cores: list[int]) -> None:
    """Confine every thread of this process to ``cores`` (threads made later inherit them)."""
    for task in Path("/proc/self/task").iterdir():
        with contextlib.suppress(OSError, ValueError):  # a thread that ended meanwhile
            os.sched_setaffinity(int(task.name), cores)


def dask_setup(worker: Any) -> None:
    """Dask's preload hook: pin this worker to its cores, when the cluster says which."""
    import dask

    shares = dask.config.get(CORES_KEY, default=None)
    name = str(worker.name)
    if not shares or not name.isdigit():
        return
    with contextlib.suppress(OSError, ValueError, TypeError):
        cores = [int(core) for core in shares[int(name) % len(shares)]]
        pin_process(cores)
        _pin_zygote(cores)


def _pin_zygote(cores: list[int]) -> None:
    """The worker's zygote too, when it was forked before this hook (a forked worker forks it
    as it starts, :mod:`.workerboot`): single-threaded, its children forked later inherit
    its cores as they would the worker's."""
    from fmionnx.runtime.isolated.launcher import zygote_pid

    pid = zygote_pid()
    if pid is not None:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(pid, cores)
