"""A value that belongs to the process that made it.

A forked child inherits its parent's memory, but some state must not travel with it: a
thread (it does not exist in the child), a pool of loaded libraries (the parent's to use), a
flag saying what the parent already did. :class:`ProcessLocal` remembers the id of the process
that made its value; in any other process it holds nothing, and the child makes its own.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


class ProcessLocal(Generic[T]):
    """One value per process: made on first use, unseen by a forked child."""

    def __init__(self) -> None:
        self._owner: int | None = None
        self._value: T | None = None
        self._lock = threading.Lock()

    def get(self) -> T | None:
        """This process's value, or None when it has made none."""
        return self._value if self._owner == os.getpid() else None

    def get_or_make(self, make: Callable[[], T]) -> T:
        """This process's value, made by ``make`` the first time (once, across threads)."""
        with self._lock:
            pid = os.getpid()
            if self._owner != pid or self._value is None:
                self._value, self._owner = make(), pid
            return self._value

    def clear(self) -> T | None:
        """Forget this process's value; returns it (None when there was none)."""
        with self._lock:
            value = self.get()
            self._value, self._owner = None, None
            return value
