"""The Dask settings of a local cluster, in a module of their own that imports nothing: the
local workers' fork server (:mod:`.workerboot`) reads them before it loads any library."""

from __future__ import annotations

#: Dask's configuration key of the variables its nanny sets before it starts a worker.
PRE_SPAWN = "distributed.nanny.pre-spawn-environ"
#: How often the local cluster's scheduler retries a task whose worker died: never. The driver
#: does it (:func:`.engine.run_study` runs the task's cases again, alone), and Dask would charge the
#: death to every task queued on that worker, not only to the one that crashed it.
ALLOWED_FAILURES = 0
#: Dask settings of the local cluster (its workers take them too).
LOCAL_CONFIG = {
    "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
    # The statistical profiler samples every worker's stack 100 times a second, taking the
    # GIL from the case: a cost per case, for a profile nobody reads (no dashboard).
    "distributed.worker.profile.enabled": False,
    # Dask's nanny starts each worker with MALLOC_TRIM_THRESHOLD_=65536 (to hand freed memory
    # back to the OS at once). Setting it at all also turns off glibc's adaptive mmap
    # threshold, so every buffer over 128 KiB (a rendered frame, a tensor) is mapped and
    # unmapped afresh and page-faulted in on every step: the reference scenario's case ran
    # 16 % slower than in a plain process. None leaves the variable unset (as the driver has
    # it): a worker allocates as any process does.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    # Every Dask server (the scheduler, each nanny, each worker) wakes every 20 ms by default
    # only to measure how late its event loop is (a statistic, and a warning after 3 s): an
    # idle local cluster of 2 workers took 5-7 % of a core, and a busy worker's loop took the
    # GIL from its case 50 times a second. At 500 ms (what Dask's own test clusters use) the
    # idle cluster takes under 2 %.
    "distributed.admin.tick.interval": "500ms",
    # A task sent to the worker that had just returned one, as that worker died, stayed
    # unrunnable for ever once new workers replaced it: Dask keeps a task whose named worker
    # is gone in ``no-worker`` even when the restriction is loose (the engine hands such tasks
    # out again when it learns of the death; this catches the orderings it cannot see). After
    # this long unrunnable, or with no worker at all, a task fails, and the engine runs its
    # cases again, alone (a worker restarts in 1-3 s).
    "distributed.scheduler.no-workers-timeout": "15s",
    # Workers leave Ctrl-C to the driver, which closes them in order (see the module).
    "distributed.worker.preload": [
        "fmionnx.backends.sweep.quiet",
        "fmionnx.backends.sweep.pinning",
    ],
}
