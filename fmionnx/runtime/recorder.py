"""Recording at each component's own rate, expanded to the base-step grid at the end.

Copying every recorded signal at every base step would cost the fast loop for values that
only change when their component steps. Instead each component appends one row per step of
its own (outputs after the step, inputs as used by the step), and :meth:`Recorder.table`
expands the rows to base-step times by holding, which is exactly what a slower component's
values do in the run.

Rows are float64, which holds every value of every port exactly but those of 64-bit integers
beyond 2**53 (``9007199254740993`` read as ``...992``: a bug hunt). A recorded int64 or
uint64 buffer therefore fills two columns: its value as float64, under its name, as every
reader of the rows takes it (the native kernel, the guardian's shared tracks, a follower
formatting ahead, live plots); and its eight bytes unchanged, under :func:`exact_column`'s
name, which only :meth:`Recorder.at` reads, to give the table the integers exactly. The bytes
travel as a float64 column, so every path that copies rows copies them bit for bit, and a
system without such ports records exactly as before.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt

from fmionnx.core.runner import Buffer

#: Rows reserved up front; long runs grow by doubling instead of reserving hours of rows.
CHUNK_ROWS = 1 << 16

#: Starts the name of a column holding a 64-bit integer's bytes (no signal name has it).
EXACT_MARK = "\x1f"  # the unit separator


def exact_column(name: str, dtype: np.dtype[np.generic]) -> str:
    """The name of the column holding the bytes of column ``name``, of integer ``dtype``."""
    return f"{EXACT_MARK}{dtype.name}{EXACT_MARK}{name}"


def is_exact_integer(dtype: np.dtype[np.generic]) -> bool:
    """Integers float64 cannot hold exactly (int64, uint64): recorded by their bytes too."""
    return dtype.kind in "iu" and dtype.itemsize == 8


class FrameSink(Protocol):
    """Receives camera frames as they are rendered (e.g. an MCAP writer)."""

    def frame(self, component: str, port: str, time: float, image: Buffer) -> None:
        """One rendered frame of ``component.port`` at simulated ``time``."""
        ...


@dataclass
class Track:
    """The recorded ports of one component, side (inputs or outputs) and period."""

    period_steps: int
    capacity: int
    columns: list[str] = field(default_factory=list)
    views: list[tuple[Buffer, int, int]] = field(default_factory=list)
    rows: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    count: int = 0
    #: The place in the execution order of the work sampling it (-1: not known), and whether
    #: it holds outputs (sampled after the step, with a first row at the start time): what
    #: the guardian needs to take back rows after a crash as the parallel master does.
    place: int = -1
    outputs: bool = False
    #: The one name a port of a size known only at run time was given, by the columns its
    #: buffer fills (see :meth:`add`).
    widened: dict[str, list[str]] = field(default_factory=dict)

    def add(self, names: list[str], view: Buffer) -> None:
        """Record ``view`` (flat) under ``names``, one column per element; a 64-bit integer
        view also under :func:`exact_column`'s names, by its bytes (see the module)."""
        names = self._sized(names, view)
        self._add(names, view)
        if is_exact_integer(view.dtype):
            self._add([exact_column(n, view.dtype) for n in names], view.view(np.float64))

    def _sized(self, names: list[str], view: Buffer) -> list[str]:
        """``names``, or the flat names of every element of ``view`` when ``names`` is the
        one column a port with a dimension known only at run time is named by before the run
        (``comp.port[0]``, :func:`fmionnx.core.signals.column_names`) and its buffer holds
        another count: an ONNX output ``[batch, 3]`` whose ``batch`` the inputs fixed. One
        column for three values crashed the first sample (a bug hunt)."""
        if len(names) != 1 or view.size == 1 or not names[0].endswith("[0]"):
            return names
        stem = names[0][: -len("[0]")]
        wide = [f"{stem}[{i}]" for i in range(view.size)]
        self.widened[names[0]] = wide
        return wide

    def _add(self, names: list[str], view: Buffer) -> None:
        start = len(self.columns)
        self.columns.extend(names)
        self.views.append((view, start, start + view.size))

    def allocate(self) -> None:
        """Reserve rows before the loop (all of them for runs up to :data:`CHUNK_ROWS`)."""
        rows = min(self.capacity, CHUNK_ROWS)
        self.rows = np.zeros((rows, len(self.columns)), dtype=np.float64)

    def _grow(self) -> None:
        extra = min(max(len(self.rows), CHUNK_ROWS), self.capacity - len(self.rows))
        self.rows = np.concatenate([self.rows, np.zeros((max(extra, 1), len(self.columns)))])

    def reserve(self) -> None:
        """Make room for the next row (the native loop samples into :attr:`rows` itself)."""
        if self.count == len(self.rows):
            self._grow()

    def count_address(self) -> int:
        """Where a native sampler publishes the count after each row; 0: nowhere (only
        :attr:`count`, which it hands back)."""
        return 0

    def sample(self) -> None:
        """Append the current values as the next row."""
        if self.count == len(self.rows):
            self._grow()
        row = self.rows[self.count]
        for view, a, b in self.views:
            if b - a == 1:
                row[a] = view[0]
            else:
                row[a:b] = view
        self.count += 1

    def truncate(self, count: int) -> None:
        """Keep at most the first ``count`` rows (a step taken back: see the parallel master)."""
        self.count = min(self.count, count)


class Recorder:
    """All tracks of a run; :meth:`table` builds the base-step columns."""

    def __init__(self) -> None:
        self.tracks: list[Track] = []
        self.order: list[str] = []

    def track(self, period_steps: int, total_steps: int) -> Track:
        """A new track for a component stepping every ``period_steps`` base steps."""
        track = Track(period_steps, total_steps // period_steps + 2)
        self.tracks.append(track)
        return track

    def table(self, steps_done: int) -> dict[str, npt.NDArray[np.float64]]:
        """Columns at base steps ``0..steps_done`` (held between a component's steps)."""
        return self.at(np.arange(steps_done + 1))

    def at(self, index: npt.NDArray[np.int64]) -> dict[str, npt.NDArray[np.float64]]:
        """Columns at the base steps ``index`` (held between a component's steps; a row not
        recorded yet holds the newest one): a live view's rows while the run goes."""
        out: dict[str, npt.NDArray[np.float64]] = {}
        for track in self.tracks:
            if not track.columns or track.count == 0:
                continue
            rows = np.minimum(index // track.period_steps, track.count - 1)
            values = track.rows[rows]
            for column, name in enumerate(track.columns):
                out[name] = values[:, column]
        widened = {one: wide for track in self.tracks for one, wide in track.widened.items()}
        order = [name for one in self.order for name in widened.get(one, [one])]
        table = {name: out[name] for name in order if name in out}
        if len(out) > len(table):  # columns beside the signals: 64-bit integers' bytes
            for key, values in out.items():
                if key.startswith(EXACT_MARK):
                    _, dtype, name = key.split(EXACT_MARK, 2)
                    if name in table:
                        table[name] = values.view(np.dtype(dtype))
        return table
