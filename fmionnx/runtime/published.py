"""The rows a guarded run has published so far, read by the guardian while the run goes on.

Under the guardian (:mod:`fmionnx.runtime.guardian`) the run's child process records into a
shared file; the guardian, idle on the second core meanwhile, can put the rows to use before
the run ends (``results.csv`` formatted ahead: :mod:`fmionnx.results.csvahead`). This module
reads them, and trusts nothing it reads: the child runs native models that may scribble over
its memory, and may die or be hostile.

- The file is sealed against shrinking (the guardian seals it before the fork), so a mapping
  of the size the guardian saw stays valid; without the seal nothing is read here.
- The directory is parsed defensively; every track's region is checked to lie inside the
  mapping, and its row count is clamped to the region's capacity.
- Only rows below a track's published count are read: the child writes a row, then the
  count. A track that grows moves to a new region and is published again; the old region's
  pages are then given back (it reads as zeros), so a reader that read the directory before
  the move may read zeros there: hence the comparison below.

The values read here are never trusted to be *final* either: a reader must compare them with
the run's result before use (a parallel run's fault takes rows back; a hostile child could
rewrite them). :mod:`fmionnx.results.csvahead` compares them bit for bit.
"""

from __future__ import annotations

import contextlib
import mmap
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from fmionnx.runtime.result import RunResult

#: Directories listing more tracks or columns than this are not believed.
MAX_TRACKS = 1 << 16
MAX_COLUMNS = 1 << 20


@dataclass(frozen=True)
class _Region:
    """A track's place in the shared file, as the directory gave it (checked)."""

    offset: int
    capacity: int
    columns: tuple[str, ...]
    period: int


#: A piece of work the guarded child did for the follower: (first row, values, bytes).
TailPiece = tuple[int, npt.NDArray[np.float64], bytes]


class Follower(Protocol):
    """Puts a guarded run's published rows to use while the run goes on (guardian side), and
    takes a share of the same work in the child once its run has ended."""

    def follow(self, published: Published) -> bool:
        """Do a bounded piece of work; True when more may be ready at once (call again)."""
        ...

    @property
    def front(self) -> int:
        """How far :meth:`follow` got (rows from the start): where :meth:`tail` stops."""
        ...

    def tail(self, result: RunResult, front: Callable[[], int]) -> Iterator[TailPiece]:
        """In the child, after the run: pieces of work from the end until ``front()``."""
        ...

    def adopt(self, pieces: Sequence[TailPiece]) -> None:
        """Take the pieces the child made (read back from the shared file)."""
        ...


class Published:
    """The base-step table as far as the guarded child has published it.

    ``refresh`` reads the directory and the row counts; then ``horizon`` base steps
    (``0 .. horizon - 1``) have a row in every track, ``names`` are the table's columns (as
    :meth:`fmionnx.runtime.recorder.Recorder.table` orders them) and :meth:`values` reads
    them at given base steps.
    """

    def __init__(
        self, fd: int, directory: Callable[[], dict[str, Any] | None], steps: int, *, sealed: bool
    ) -> None:
        self._fd = fd
        self._directory = directory
        self._rows = steps + 1  # a table has at most one row per base step and the start
        self._sealed = sealed
        self._view: mmap.mmap | None = None
        self._size = 0
        self._regions: list[tuple[_Region, int]] = []  # (region, rows published)
        #: name -> (index into the regions, column)
        self._where: dict[str, tuple[int, int]] = {}
        self.names: list[str] = []
        self.horizon = 0

    def refresh(self) -> int:
        """Read what is published now; returns :attr:`horizon` (0: nothing usable)."""
        self.horizon = 0
        self._regions, self._where, self.names = [], {}, []
        view = self._map()
        directory = self._directory()
        if view is None or not isinstance(directory, dict):
            return 0
        regions = _regions(directory.get("tracks"), len(view))
        order = directory.get("order")
        if regions is None or not isinstance(order, list) or len(order) > MAX_COLUMNS:
            return 0
        horizon = self._rows
        where: dict[str, tuple[int, int]] = {}
        kept: list[tuple[_Region, int]] = []
        for region in regions:
            count = int.from_bytes(view[region.offset : region.offset + 8], "little", signed=True)
            count = max(0, min(count, region.capacity))
            if not region.columns or count == 0:  # left out of the table (as the recorder does)
                continue
            horizon = min(horizon, count * region.period)
            for column, name in enumerate(region.columns):
                where[name] = (len(kept), column)
            kept.append((region, count))
        names = [n for n in order if isinstance(n, str) and n in where]
        if len(set(names)) != len(names) or not kept:
            return 0
        self._regions, self._where, self.names = kept, where, names
        self.horizon = horizon
        return horizon

    def values(self, steps: npt.NDArray[np.int64]) -> npt.NDArray[np.float64]:
        """The columns :attr:`names` at base ``steps`` (sorted, each below :attr:`horizon`)."""
        if len(steps) and not (steps[0] >= 0 and steps[-1] < self.horizon):
            raise ValueError("base steps beyond what is published")
        view = self._view
        out = np.empty((len(steps), len(self.names)), dtype=np.float64)
        if not len(steps):
            return out
        assert view is not None
        cache: dict[int, tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]] = {}
        for j, name in enumerate(self.names):
            track, column = self._where[name]
            if track not in cache:
                region, count = self._regions[track]
                index = steps // region.period
                first, last = int(index[0]), int(index[-1]) + 1
                width = len(region.columns)
                last = min(last, count)  # guaranteed by the horizon; checked again
                start = region.offset + 8 + first * width * 8
                rows = np.frombuffer(view, np.float64, (last - first) * width, start).copy()
                cache[track] = (rows.reshape(last - first, width), index - first)
            rows, index = cache[track]
            out[:, j] = rows[index, column]
        return out

    def close(self) -> None:
        if self._view is not None:
            with contextlib.suppress(BufferError):
                self._view.close()
            self._view = None

    def _map(self) -> mmap.mmap | None:
        """A read-only mapping of the whole file, remapped when it grew (sealed files only)."""
        if not self._sealed:
            return None
        size = os.fstat(self._fd).st_size
        if self._view is None or size > self._size:
            self.close()
            self._view = mmap.mmap(self._fd, size, prot=mmap.PROT_READ)
            self._size = size
        return self._view


def _regions(tracks: object, size: int) -> list[_Region] | None:
    """The directory's tracks, each checked to lie inside ``size`` bytes; None if any does not."""
    if not isinstance(tracks, list) or len(tracks) > MAX_TRACKS:
        return None
    regions = []
    for entry in tracks:
        if not isinstance(entry, dict):
            return None
        offset, capacity = _whole(entry.get("offset")), _whole(entry.get("capacity"))
        period, columns = _whole(entry.get("period")), entry.get("columns")
        if offset is None or capacity is None or period is None or period < 1:
            return None
        if not isinstance(columns, list) or len(columns) > MAX_COLUMNS:
            return None
        if not all(isinstance(c, str) for c in columns):
            return None
        if offset + 8 + capacity * len(columns) * 8 > size:
            return None
        regions.append(_Region(offset, capacity, tuple(columns), period))
    return regions


def _whole(value: object) -> int | None:
    """``value`` if it is a whole number >= 0 (JSON's ``true`` is not), else None."""
    if isinstance(value, int) and not isinstance(value, bool) and value >= 0:
        return value
    return None


__all__ = ["Follower", "Published", "TailPiece"]
