"""The main module of a process ``multiprocessing`` spawns from the ``fmionnx`` command (a
local study's Dask workers): it makes the process ignore SIGINT from its first statements.

A terminal's Ctrl-C goes to its whole foreground process group, and a study's driver decides
what happens then (the finished cases kept, the cluster closed in order). A worker ignores
SIGINT once Dask's preload ran (:mod:`fmionnx.backends.sweep.quiet`), but before that it
imports Dask's ``distributed`` for half a second, and a Ctrl-C then printed a
``KeyboardInterrupt`` traceback per worker. A spawned process runs the main module of its
parent before anything else (before it unpickles what it is to run); the command gives its
main module this one's name (:func:`fmionnx.cli._children_skip_the_script`), so this is all a
worker runs of it, at once.

Only a process being started by ``multiprocessing`` is touched: imported anywhere else, this
module changes nothing.
"""

from __future__ import annotations

import signal
from multiprocessing import process

if getattr(process.current_process(), "_inheriting", False):
    signal.signal(signal.SIGINT, signal.SIG_IGN)
