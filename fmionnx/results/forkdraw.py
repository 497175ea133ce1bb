"""Figures drawn side by side by forked copies of the plot worker.

A figure costs matplotlib about half a second here (tick and text layout, the legend's
placement, the PNG encoder), all of it in one thread, and a run waits for its last figure
before it ends. The plot worker (:mod:`.plotworker`) is a process of its own with matplotlib
imported and no thread besides its main one, so :func:`os.fork` copies it safely and at once:
each copy draws every n-th figure of the job and writes its files (atomically, as always),
and tells the worker which files it wrote and what it logged. The figures are the same, byte
for byte: the same functions draw them from the same data.

Only the plot worker forks here, never the run's process once it runs (it has threads then:
a copy of it could wait for ever on a lock one of them held; it forks its helpers only before,
while it has one, :mod:`fmionnx.core.forking`). A copy that fails or dies makes the whole job fail:
the worker answers so, and the run draws the figures itself.
"""

from __future__ import annotations

import contextlib
import os
import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.core.cores import usable_cores
from fmionnx.runtime.lifetime import die_with_parent

if TYPE_CHECKING:
    from fmionnx.results.plots import Drawing

#: What a copy sends back: the files it wrote (None: it failed), why not, what it logged.
_Report = tuple[list[Path] | None, str, list[tuple[int, str]]]


class DrawingFailedError(Exception):
    """A forked copy could not draw its share (its reason is the message)."""


def processes_for(figures: int) -> int:
    """How many processes draw ``figures`` figures: one each, up to the usable cores."""
    return max(1, min(figures, usable_cores()))


def draw_side_by_side(
    drawings: Sequence[Drawing],
    processes: int,
    logged: list[tuple[int, str]],
) -> list[Path]:
    """Draw ``drawings`` with ``processes`` processes (this one and forked copies); returns
    the files in the drawings' order. ``logged`` is this process's list of log records: the
    copies' records are added to it. Raises what this process's share raised, or
    :class:`DrawingFailedError` when a copy failed."""
    share_count = max(1, min(processes, len(drawings)))
    copies: list[tuple[int, int, int]] = []  # (share, pid, read end)
    try:
        for share in range(1, share_count):
            copies.append(_fork_copy(drawings, share, share_count, len(logged), logged))
        files: dict[int, Path] = {}
        for index in range(0, len(drawings), share_count):
            files[index] = drawings[index]()
    finally:
        reports = [(share, _report_of(pid, read)) for share, pid, read in copies]
    for share, (written, problem, records) in reports:
        logged.extend(records)
        if written is None:
            raise DrawingFailedError(problem)
        files.update(zip(range(share, len(drawings), share_count), written, strict=True))
    return [files[index] for index in range(len(drawings))]


def _fork_copy(
    drawings: Sequence[Drawing],
    share: int,
    shares: int,
    logged_before: int,
    logged: list[tuple[int, str]],
) -> tuple[int, int, int]:
    read, write = os.pipe()
    pid = os.fork()
    if pid != 0:
        os.close(write)
        return share, pid, read
    os.close(read)  # the copy: draw, report, and leave without the worker's clean-up
    code = 0
    try:
        die_with_parent()
        written = [drawings[index]() for index in range(share, len(drawings), shares)]
        report: _Report = (written, "", logged[logged_before:])
    except BaseException as exc:  # reported to the worker, which says so
        report = (None, f"{type(exc).__name__}: {exc}", logged[logged_before:])
        code = 1
    try:
        with os.fdopen(write, "wb") as stream:
            stream.write(pickle.dumps(report))
    finally:
        os._exit(code)


def _report_of(pid: int, read: int) -> _Report:
    """A copy's report, once it has ended."""
    with os.fdopen(read, "rb") as stream:
        data = stream.read()
    with contextlib.suppress(ChildProcessError):
        os.waitpid(pid, 0)
    try:
        report = pickle.loads(data)  # our own copy's: trusted
    except Exception:  # it died before it could say
        return None, "a drawing process ended without a report", []
    return report  # type: ignore[no-any-return]
