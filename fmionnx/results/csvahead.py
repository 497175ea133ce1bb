"""``results.csv`` formatted ahead, while a guarded run goes on.

Formatting the table's numbers is about as costly as the loop of a run of one fast FMU
(200 000 rows: ~0.27 s against ~0.28 s). Under the guardian the run steps in a child process
and this process waits, idle, on the second core; :class:`CsvAhead`, the guardian's follower
(:mod:`fmionnx.runtime.published`), formats the rows the child has published in pieces of
:data:`PIECE_ROWS`, so that when the run ends only the rest is formatted.

A run that ends long before its rows are formatted (a lone FMU's native loop steps 200 000
times in 0.03 s) leaves most of the work for the end. The guarded child then takes a share:
before it sends its result, it formats pieces of the result's rows *from the end*
(:meth:`CsvAhead.tail`, run in the child), while this process goes on from the front; the
child stops where the two meet (the guardian tells it how far the front is) and leaves its
pieces in the shared file, where this process adopts them (:meth:`CsvAhead.adopt`). The two
cores format side by side.

The file stays exactly what :func:`~fmionnx.results.csvfile.write_csv` writes from the run's
result: a piece's text is used only when the result's rows there are *bit for bit* the values
the piece was formatted from; anything else (rows a faulted
parallel run took back, a last row that is not on the output grid, a child that rewrote its
memory) is formatted from the result as without this module. The text of a row depends on its
values alone, so where the pieces start changes no byte.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.switches import switched_off
from fmionnx.runtime.published import Published, TailPiece
from fmionnx.runtime.result import RunResult

#: The environment variable that leaves results.csv to be formatted at the run's end (``0``):
#: neither the guardian nor a plot worker formats rows while the run goes on.
SWITCH = "FMIONNX_CSV_AHEAD"


def allowed() -> bool:
    """Whether results.csv may be formatted while a run goes on at all (not
    ``FMIONNX_CSV_AHEAD=0``): by the guardian, or by a plot worker (:mod:`.csvfollow`)."""
    return not switched_off(SWITCH)


#: Rows formatted per piece: small enough that little is left when the run ends, large
#: enough that the per-call cost of formatting stays negligible.
PIECE_ROWS = 8192
#: Bytes of text and values kept ahead at most. Formatting at the end streams the file in
#: blocks; text formatted ahead is held until then, so a very long run stops formatting ahead
#: here (about 8 million rows of two columns) and formats the rest at the end, as before.
MAX_AHEAD_BYTES = 256 << 20


@dataclass(frozen=True)
class _Piece:
    values: npt.NDArray[np.float64]  # (rows, 1 + signals): time, then the signals
    text: str


class CsvAhead:
    """Pieces of ``results.csv``'s rows formatted while the run goes on (see the module)."""

    def __init__(
        self, start: float, step: float, every: int, *, piece_rows: int = PIECE_ROWS
    ) -> None:
        """Rows on the grid of a run from ``start`` by ``step``, a row every ``every`` base
        steps (:meth:`of`), formatted in pieces of ``piece_rows``."""
        self._start, self._step = start, step
        self._every = max(1, every)
        self._piece = max(1, piece_rows)
        self._pieces: dict[int, _Piece] = {}  # first row -> piece
        self._next = 0  # the next piece's first row
        self._names: list[str] | None = None
        self._bytes = 0  # text and values held (see MAX_AHEAD_BYTES)

    @classmethod
    def of(cls, system: CompiledSystem, *, piece_rows: int = PIECE_ROWS) -> CsvAhead:
        """For a run of ``system`` (its start, step and output interval)."""
        run = system.run
        return cls(run.start, run.step, run.output_every, piece_rows=piece_rows)

    def follow(self, published: Published) -> bool:
        """Format the next piece if the child has published every row it needs."""
        if self._bytes >= MAX_AHEAD_BYTES:
            return False
        first = self._next
        rows = np.arange(first, first + self._piece, dtype=np.int64)
        steps = rows * self._every  # the base steps of those rows (RunResult.after's grid)
        if published.refresh() <= steps[-1]:
            return False
        if published.names != self._names:  # the columns changed: start again
            self._names, self._pieces, self._next = list(published.names), {}, 0
            self._bytes = 0
            return True
        from fmionnx.results.csvfile import format_rows

        time = self._start + steps * self._step  # exactly as RunResult.after computes it
        values = np.column_stack([time, published.values(steps)])
        text = format_rows(values)
        self._pieces[first] = _Piece(values, text)
        self._next = first + self._piece
        self._bytes += len(text) + values.nbytes
        return True

    @property
    def rows(self) -> int:
        """Rows formatted ahead so far."""
        return len(self._pieces) * self._piece

    @property
    def front(self) -> int:
        """The first row this process has not formatted from the front (it may be at it)."""
        return self._next

    def tail(self, result: RunResult, front: Callable[[], int]) -> Iterator[TailPiece]:
        """In the guarded child: pieces of ``result``'s rows formatted from the end, each as
        (first row, values, ASCII text), until the next one would start at or below
        ``front()`` (the guardian's front) or :data:`MAX_AHEAD_BYTES` are spent."""
        from fmionnx.results.csvfile import format_rows, result_table

        table = result_table(result)
        first = (len(table) - 1) // self._piece * self._piece
        spent = 0
        while first > front() and spent < MAX_AHEAD_BYTES:
            values = table[first : first + self._piece]
            text = format_rows(values).encode("ascii")
            spent += len(text) + values.nbytes
            yield first, values, text
            first -= self._piece

    def adopt(self, pieces: Sequence[TailPiece]) -> None:
        """Take the child's pieces (:meth:`tail`); a piece is used only where its values are
        the result's, bit for bit (:meth:`text`), like every other."""
        for first, values, text in pieces:
            if first % self._piece == 0 and first not in self._pieces:
                self._pieces[first] = _Piece(values, text.decode("ascii"))

    def text(self, table: npt.NDArray[np.float64], first: int) -> tuple[str, int] | None:
        """(text, rows) of ``table``'s rows from ``first``, when a piece formatted ahead starts
        there, lies inside ``table`` and holds exactly its values; else None.

        Equal bits give equal text, whatever the columns are called (a lone FMU's result
        names them after its variables, the child's recorder after the component's ports).
        """
        piece = self._pieces.get(first)
        if piece is None:
            return None
        rows = table[first : first + len(piece.values)]
        if rows.shape != piece.values.shape:
            return None
        if not np.array_equal(rows.view(np.uint64), piece.values.view(np.uint64)):
            return None
        return piece.text, len(piece.values)

    def next_start(self, first: int) -> int | None:
        """Where the next piece after row ``first`` starts (None: no piece after it)."""
        later = (first // self._piece + 1) * self._piece
        return later if later in self._pieces else None


__all__ = ["MAX_AHEAD_BYTES", "PIECE_ROWS", "SWITCH", "CsvAhead", "allowed"]
