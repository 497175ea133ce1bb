"""FMU libraries kept loaded between runs of one process: a sweep worker's cases.

A run unpacks each FMU into a scratch folder, loads its shared library, instantiates, and at the
end frees the instance, unloads the library and removes the folder. For a case of a few
milliseconds those file-system and loader steps are most of the case (unzip, ``dlopen``, fmpy
binding some thirty functions, ``rmtree``), and they are kernel work that two worker processes
on one machine do not do side by side at full speed.

A process that runs many cases can keep them instead (:func:`keep_libraries`, called by the
sweep worker): when a run ends cleanly, its FMU's unpacked folder and loaded library go back
to this process's pool, and the next run of the same FMU file takes them and makes only a new
instance. That is FMI's own model of several instances of one FMU in one process, and it is
used only where the FMU allows it:

* the model description does not say ``canBeInstantiatedOnlyOncePerProcess="true"`` for the
  interface type in use (an FMU that says so gets its own unpacked copy every run, as before);
* the run ended cleanly: an FMU whose instance faulted, crashed a call or refused to terminate
  is unloaded and its folder removed (after ``fmi2Fatal`` FMI calls every instance of the
  library corrupt);
* the pool belongs to the process that enabled it: a child forked from it (the guardian) does
  not use its parent's pool, and an isolated FMU runs in a fresh process of its own anyway.

Each run still gets its own instance, parameters and start values, so a case's results are
those of a run alone (``tests/sweep`` compares every case with a direct run).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmionnx.core.processlocal import ProcessLocal
from fmionnx.core.scratch import remove_scratch

#: Unused loaded FMUs one process keeps at most; the least recently used one is unloaded first.
MAX_IDLE = 16

#: What makes two runs' FMUs the same: the file (path, mtime, size), and the runner class
#: (FMI version and interface type).
LibraryKey = tuple[str, int, int, str]


@dataclass
class LoadedFmu:
    """An FMU unpacked and loaded, without an instance: fmpy's object and its model description."""

    key: LibraryKey
    md: Any
    fmu: Any
    #: The scratch folder it was unpacked into (None for an unpacked FMU folder).
    scratch: Path | None

    def unload(self) -> None:
        """Unload the library and remove the folder it was unpacked into."""
        try:
            self.fmu.freeLibrary()
        finally:
            if self.scratch is not None:
                remove_scratch(self.scratch)


class LibraryPool:
    """Loaded FMUs without an instance, by :data:`LibraryKey`; thread-safe."""

    def __init__(self, capacity: int = MAX_IDLE) -> None:
        self.capacity = capacity
        self._idle: OrderedDict[int, LoadedFmu] = OrderedDict()
        self._lock = threading.Lock()
        self._serial = 0

    def take(self, key: LibraryKey) -> LoadedFmu | None:
        """An idle loaded FMU of ``key``, now the caller's; None when there is none."""
        with self._lock:
            for serial, loaded in reversed(self._idle.items()):
                if loaded.key == key:
                    del self._idle[serial]
                    return loaded
        return None

    def give(self, loaded: LoadedFmu) -> None:
        """Keep ``loaded`` for a later run; the oldest idle ones beyond the capacity go."""
        evicted = []
        with self._lock:
            self._serial += 1
            self._idle[self._serial] = loaded
            while len(self._idle) > self.capacity:
                evicted.append(self._idle.popitem(last=False)[1])
        for old in evicted:
            old.unload()

    def __len__(self) -> int:
        with self._lock:
            return len(self._idle)

    def idle(self) -> tuple[LoadedFmu, ...]:
        """The loaded FMUs waiting for a run, oldest first."""
        with self._lock:
            return tuple(self._idle.values())

    def clear(self) -> None:
        """Unload every idle FMU."""
        with self._lock:
            idle = list(self._idle.values())
            self._idle.clear()
        for loaded in idle:
            loaded.unload()


#: This process's pool (a forked child has none of its own until it asks).
_POOL: ProcessLocal[LibraryPool] = ProcessLocal()


def keep_libraries() -> LibraryPool:
    """Keep cleanly ended FMUs loaded for the next runs of this process (idempotent)."""
    return _POOL.get_or_make(LibraryPool)


def stop_keeping_libraries() -> None:
    """Unload what this process keeps and go back to one library per run (tests, embedders)."""
    pool = _POOL.clear()
    if pool is not None:
        pool.clear()


def active_pool() -> LibraryPool | None:
    """The pool of this very process, or None when it keeps no libraries."""
    return _POOL.get()


def library_key(path: Path, runner: type) -> LibraryKey | None:
    """The pool key of the FMU at ``path`` run by ``runner``; None when it cannot be read."""
    target = path / "modelDescription.xml" if path.is_dir() else path
    try:
        stat = target.stat()
    except OSError:
        return None
    return (
        str(path.resolve()),
        stat.st_mtime_ns,
        stat.st_size,
        f"{runner.__module__}.{runner.__qualname__}",
    )


def shareable(interface_element: Any) -> bool:
    """Whether the model description lets several instances share one loaded library."""
    once = getattr(interface_element, "canBeInstantiatedOnlyOncePerProcess", False)
    return not (once is True or str(once).lower() == "true")
