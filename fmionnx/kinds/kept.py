"""What a process that runs many runs keeps between them: a study's worker.

A case of the reference scenario used to load its scene, create an offscreen GL context with
the scene's textures and meshes uploaded, and build an onnxruntime session, then throw all of
it away, for the next case of the same models to do it again (a tenth of a short case). A
kind whose runners make such objects keeps them here once its worker settings ask for it
(:class:`~fmionnx.kinds.base.WorkerSettings`): a run *takes* an object (it is then the run's
alone, so two cases on two threads of one worker never share one) and gives it back when it
ends cleanly; the next run of the same model takes it instead of making a new one.

The pool belongs to the process that enabled it: a forked child (the guardian's) sees none,
since a GL context or a session thread does not survive a fork. It holds a few objects per
kind at most, the least recently given back closed first.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

from fmionnx.core.processlocal import ProcessLocal

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")

#: Idle objects one pool keeps at most.
CAPACITY = 4


class _Idle(Generic[K, V]):
    def __init__(self) -> None:
        self.items: OrderedDict[int, tuple[K, V]] = OrderedDict()
        self.serial = 0
        self.lock = threading.Lock()


class Kept(Generic[K, V]):
    """Idle objects by key, kept only in a process that called :meth:`enable`."""

    def __init__(self, close: Callable[[V], None], capacity: int = CAPACITY) -> None:
        self._close = close
        self.capacity = capacity
        self._idle: ProcessLocal[_Idle[K, V]] = ProcessLocal()

    def enable(self) -> None:
        """From now on, this process keeps what runs give back (idempotent)."""
        self._idle.get_or_make(_Idle)

    @property
    def enabled(self) -> bool:
        """Whether this process keeps objects."""
        return self._idle.get() is not None

    def take(self, key: K) -> V | None:
        """An idle object of ``key``, now the caller's alone; None when there is none."""
        idle = self._idle.get()
        if idle is None:
            return None
        with idle.lock:
            for serial, (found, value) in reversed(idle.items.items()):
                if found == key:
                    del idle.items[serial]
                    return value
        return None

    def give(self, key: K, value: V) -> None:
        """Keep ``value`` for the next run of ``key`` (or close it: nothing is kept here)."""
        idle = self._idle.get()
        if idle is None:
            self._close(value)
            return
        with idle.lock:
            idle.serial += 1
            idle.items[idle.serial] = (key, value)
            surplus = []
            while len(idle.items) > self.capacity:
                surplus.append(idle.items.popitem(last=False)[1][1])
        for old in surplus:
            self._close(old)

    def __len__(self) -> int:
        idle = self._idle.get()
        return 0 if idle is None else len(idle.items)

    def clear(self) -> None:
        """Close every idle object and keep nothing from now on (tests, long-lived processes)."""
        idle = self._idle.clear()
        if idle is None:
            return
        with idle.lock:
            values = [value for _, value in idle.items.values()]
            idle.items.clear()
        for value in values:
            self._close(value)
