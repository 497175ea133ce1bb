"""Plots drawn by a process of their own, started before the run and ready when it ends.

matplotlib takes longer to import than many runs take to step (about 0.3-0.6 s, more than
the reference scenario spends on everything else after its loop), and drawing is CPU work
of its own. A run that draws (a system with ``plots:``, or ``run --plot``) into a results
folder therefore starts this worker before its loop: the worker imports matplotlib on
another core while the models step; when the run ends it draws the figures while this
process writes ``results.csv``, several figures side by side in forked copies of itself
(:mod:`.forkdraw`), and it exits at once when it has answered. The figures are the same,
byte for byte: the same functions (:mod:`.plots`, :mod:`.signals_plot`) draw them from the
same data. A study's worker (``--study``) draws a study's summary plots the same way.

The worker is a fork of ``fmionnx run``'s process, made before the run starts any thread
(:mod:`fmionnx.core.forking`), else ``python -m fmionnx.results.plotworker``. Either way it
reads one job (a pickle from the process that started it, its own parent: nothing from
outside) on stdin, answers on a pipe to that process, exits. It ends when its stdin closes
(the parent finished without plots, or died). It runs in a process group of its own, out of
reach of the terminal's Ctrl-C (sent to the whole foreground group), and ignores SIGINT
besides: the parent decides when the results are written. Whatever goes wrong in the worker
(it cannot start, dies, or drawing raises), the parent draws the plots itself, so an error
is reported as it always was.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import logging
import os
import pickle
import signal
import struct
import subprocess
import sys
import traceback
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Protocol, cast

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.cores import usable_cores
from fmionnx.core.forking import (
    HELPER_ENVIRONMENT,
    ForkedProcess,
    close_all_but,
    flush_all,
    forked_helper,
    may_fork_helpers,
)
from fmionnx.core.switches import switched_off
from fmionnx.results.csvfollow import FollowRows
from fmionnx.results.forkdraw import draw_side_by_side, processes_for
from fmionnx.runtime.result import RunResult

if TYPE_CHECKING:
    from fmionnx.compile.studyir import StudyPlan
    from fmionnx.results.casetable import CaseTable
    from fmionnx.results.csvahead import CsvAhead
    from fmionnx.results.plots import Drawing
    from fmionnx.runtime.guardian import RowsShared

#: The environment variable that keeps plots in the run's own process (``0``).
SWITCH = "FMIONNX_PLOT_WORKER"
#: A message's length prefix on the pipes.
_LENGTH = struct.Struct("<Q")
LOG = logging.getLogger("fmionnx.results")


@dataclass(frozen=True)
class PlotJob:
    """What the worker draws: the system's plots and/or ``--plot``'s signals, into ``out``."""

    result: RunResult
    system: CompiledSystem
    out: Path
    system_plots: bool
    signals_plot: bool
    aliases: Mapping[str, str] | None = None
    #: Write ``results.csv`` too (the worker followed the run's rows: :mod:`.csvfollow`).
    results_csv: bool = False


@dataclass(frozen=True)
class StudyPlotJob:
    """What a study's worker draws: the summary plots of ``table`` (:mod:`.study_plots`)."""

    table: CaseTable
    plan: StudyPlan
    out: Path


@dataclass(frozen=True)
class PlotAnswer:
    """The worker's answer: the files written, or why it could not (the parent then draws),
    and what it logged (the parent logs it again, under its own logging settings)."""

    files: tuple[Path, ...] | None
    problem: str = ""
    logged: tuple[tuple[int, str], ...] = ()
    #: Rows of results.csv formatted while the run went on (:mod:`.csvfollow`).
    rows_ahead: int = 0


def wanted() -> bool:
    """Whether plots go to a worker here: not switched off, and a second core to run it on
    (on one core a second process only adds its own start)."""
    if switched_off(SWITCH):
        return False
    return usable_cores() >= 2


class PlotWorker:
    """This process's end of a plot worker (see the module docstring)."""

    def __init__(self, *, study: bool = False, follow: CompiledSystem | None = None) -> None:
        """``study``: the worker of a study (it loads the study's plots too).

        ``follow``: the system of an in-process run about to start; the worker follows its
        rows and writes ``results.csv`` (:mod:`.csvfollow`): the run records through
        :attr:`rows`.
        """
        #: The run's rows, shared with the worker (None: it does not follow them).
        self.rows: RowsShared | None = None
        #: Rows of results.csv the worker formatted while the run went on (after collect).
        self.rows_ahead = 0
        if follow is not None:
            self.rows = _shared_rows()
        passed = () if self.rows is None else (self.rows.fd,)
        try:
            self._process: _Process | None = _forked(study, passed) or _started(study, passed)
        except BaseException:  # no process could start, or a stop came meanwhile
            if self.rows is not None:
                self.rows.close()
            raise
        if follow is not None and self.rows is not None:
            run = follow.run
            message = FollowRows(self.rows.fd, run.steps, run.start, run.step, run.output_every)
            if not self._send(message):
                self.rows.close()
                self.rows = None

    @property
    def follows(self) -> bool:
        """Whether the worker follows the run's rows (and so writes ``results.csv``)."""
        return self.rows is not None and self._process is not None

    def _send(self, message: object) -> bool:
        process = self._process
        if process is None or process.stdin is None:
            return False
        try:
            _send(process.stdin, pickle.dumps(message))
        except (OSError, pickle.PickleError):
            self.close()
            return False
        return True

    def submit(self, job: PlotJob | StudyPlotJob) -> bool:
        """Hand ``job`` to the worker, which draws it while this process goes on; False if
        the worker is gone (then draw it here)."""
        process = self._process
        if process is None or process.stdin is None:
            return False
        if isinstance(job, PlotJob):
            lean = dataclasses.replace(job.result, error=None, details={}, ended_by=None)
            job = dataclasses.replace(job, result=lean)
        if not self._send(job):
            return False
        with contextlib.suppress(OSError):
            process.stdin.close()
        return True

    def collect(self) -> list[Path] | None:
        """The files the worker wrote for the submitted job, once it has; None if it could
        not draw it (it writes each file atomically, so nothing is half-written by it)."""
        process = self._process
        if process is None or process.stdout is None:
            return None
        try:
            answer = pickle.loads(_receive(process.stdout))  # our own child: trusted
        except Exception:  # anything but an answer: the plots are drawn here instead
            answer = None
        self.close()
        if not isinstance(answer, PlotAnswer):
            return None
        for level, message in answer.logged:
            LOG.log(level, "%s", message)
        self.rows_ahead = answer.rows_ahead
        return None if answer.files is None else list(answer.files)

    def close(self) -> None:
        """End the worker (it ends by itself once its stdin closes)."""
        if self.rows is not None:
            self.rows.close()  # the run's recorder keeps its mappings
        process, self._process = self._process, None
        if process is None:
            return
        for stream in (process.stdin, process.stdout):
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()
        try:
            process.wait(5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


class _Process(Protocol):
    """What :class:`PlotWorker` uses of its worker's process (``Popen``'s names)."""

    stdin: IO[bytes] | None
    stdout: IO[bytes] | None

    def wait(self, timeout: float | None = None) -> int: ...

    def kill(self) -> None: ...


def _started(study: bool, passed: tuple[int, ...]) -> subprocess.Popen[bytes]:
    """The worker as a new interpreter."""
    return subprocess.Popen(
        [sys.executable, "-m", __name__, *(["--study"] if study else [])],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        env=dict(os.environ, **HELPER_ENVIRONMENT),
        # Out of the terminal's process group: its Ctrl-C is the parent's alone. The
        # worker ignores SIGINT once its code runs, but a Ctrl-C during its imports (a
        # third of a second) printed a KeyboardInterrupt traceback. It still ends with
        # its parent (stdin closes), and ignores the terminal's job control (see main).
        process_group=0,
        pass_fds=passed,
    )


class _ForkedWorker(ForkedProcess):
    """The worker as a fork of this process, with ``Popen``'s pipes to it."""

    def __init__(self, pid: int, stdin: IO[bytes], stdout: IO[bytes]) -> None:
        super().__init__(pid, "plot worker")
        self.stdin: IO[bytes] | None = stdin
        self.stdout: IO[bytes] | None = stdout


def _forked(study: bool, passed: tuple[int, ...]) -> _ForkedWorker | None:
    """The worker as a fork of this process, where it may be one (a ``fmionnx run``
    command's process with one thread, :mod:`fmionnx.core.forking`): it has the interpreter,
    numpy and fmionnx's modules already, a third of a second of CPU that a new interpreter
    spends on 2 busy cores before it imports matplotlib. None where it may not."""
    if not may_fork_helpers():
        return None
    job_read, job_write = os.pipe()
    answer_read, answer_write = os.pipe()
    try:
        with forked_helper() as pid:
            if pid == 0:  # the worker: never return into the caller
                code = 1
                try:
                    os.setpgid(0, 0)  # out of the terminal's process group, as a started one
                    os.dup2(job_read, 0)
                    os.dup2(2, 1)  # what a library prints goes to stderr, as in a started one
                    close_all_but({answer_write, *passed})
                    os.environ.update(HELPER_ENVIRONMENT)
                    code = main(study=study, answer_fd=answer_write)
                except BaseException:
                    traceback.print_exc()
                finally:
                    flush_all()
                    os._exit(code)
            with contextlib.suppress(OSError):  # also here: in its group before this returns
                os.setpgid(pid, pid)
            os.close(job_read)
            os.close(answer_write)
            stdin, stdout = os.fdopen(job_write, "wb"), os.fdopen(answer_read, "rb")
            return _ForkedWorker(pid, stdin, stdout)
    except OSError:  # no process could be forked
        for fd in (job_read, job_write, answer_read, answer_write):
            with contextlib.suppress(OSError):
                os.close(fd)
        return None


def _shared_rows() -> RowsShared | None:
    """A sealed shared file for the run's rows, or None where there is none to be had (no
    ``memfd_create`` off Linux, a file that cannot be sealed, no descriptor left): the run
    then records privately and this process formats results.csv at its end."""
    from fmionnx.runtime.guardian import RowsShared

    try:
        rows = RowsShared()
    except (OSError, AttributeError):
        return None
    if not rows.sealed:  # a follower could not map it safely
        rows.close()
        return None
    return rows


def start(*, study: bool = False, follow: CompiledSystem | None = None) -> PlotWorker | None:
    """A plot worker (``study``: a study's; ``follow``: one that follows an in-process run
    of that system and writes its results.csv), or None where none is wanted or one cannot
    be started."""
    if not wanted():
        return None
    try:
        return PlotWorker(study=study, follow=follow)
    except OSError:
        return None


def draw_here(job: PlotJob) -> list[Path]:
    """Draw ``job`` in this process (the parent without a worker, or when the worker could
    not)."""
    return [draw() for draw in drawings(job)]


def drawings(job: PlotJob | StudyPlotJob) -> list[Drawing]:
    """The figures of ``job``, in order, each drawn and written when called."""
    if isinstance(job, StudyPlotJob):
        from fmionnx.results.study_plots import study_drawings

        return study_drawings(job.table, job.plan, job.out)
    found: list[Drawing] = []
    taken: set[str] = set()
    if job.system_plots:
        from fmionnx.results.plots import plot_drawings, plot_file_names

        found.extend(plot_drawings(job.result, job.system, job.out))
        taken.update(plot_file_names(job.system.plots))
    if job.signals_plot:
        from fmionnx.results.signals_plot import signals_drawings

        aliases = dict(job.aliases) if job.aliases is not None else None
        found.extend(
            signals_drawings(job.result, job.system, job.out, aliases=aliases, taken=taken)
        )
    return found


def _send(stream: IO[bytes], data: bytes) -> None:
    stream.write(_LENGTH.pack(len(data)) + data)
    stream.flush()


def _receive(stream: IO[bytes]) -> bytes:
    (size,) = _LENGTH.unpack(_exactly(stream, _LENGTH.size))
    return _exactly(stream, size)


def _exactly(stream: IO[bytes], size: int) -> bytes:
    """``size`` bytes from ``stream`` (buffered or not: a raw pipe returns what it has)."""
    parts: list[bytes] = []
    while size > 0:
        part = stream.read(size)
        if not part:
            raise EOFError
        parts.append(part)
        size -= len(part)
    return b"".join(parts)


class _Collect(logging.Handler):
    """The worker's log records, kept to be sent back to the parent."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[tuple[int, str]] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append((record.levelno, record.getMessage()))


def main(*, study: bool | None = None, answer_fd: int | None = None) -> int:
    """The worker: import the plotting code (``study``, else ``--study`` among the
    arguments: a study's too), then draw the one job that comes on stdin; the answer goes
    to the descriptor ``answer_fd`` (a forked worker's), else to what was stdout."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides; it ignores it by then
    # Its own process group is a background one: with ``stty tostop`` a library's warning
    # written to the terminal would stop it (SIGTTOU), and the run would wait for it.
    signal.signal(signal.SIGTTOU, signal.SIG_IGN)
    signal.signal(signal.SIGTTIN, signal.SIG_IGN)
    import matplotlib.figure  # noqa: F401 - the point of the worker: imported while the run goes on

    import fmionnx.results.plots
    import fmionnx.results.signals_plot

    if study is None:
        study = "--study" in sys.argv[1:]
    if study:
        import fmionnx.results.study_plots  # noqa: F401

    if answer_fd is None:  # on the pipe that was stdout; anything a library prints: stderr
        answer_fd = os.dup(1)
        os.dup2(2, 1)
    stdout = os.fdopen(answer_fd, "wb")
    # Unbuffered: while following a run, whether the job has come is asked of the pipe itself.
    stdin = cast(IO[bytes], io.FileIO(0, "rb", closefd=False))
    try:
        job, ahead = _job(stdin)
    except EOFError:
        return 0  # the run ended without plots to draw, or its process is gone
    collect = _Collect()
    LOG.addHandler(collect)
    LOG.propagate = False
    try:
        figures = drawings(job)
        if ahead is not None and isinstance(job, PlotJob) and job.results_csv:
            figures.insert(0, _results_csv(job, ahead))  # drawn first, beside the figures
        files = draw_side_by_side(figures, processes_for(len(figures)), collect.records)
        rows = ahead.rows if ahead is not None else 0
        answer = PlotAnswer(tuple(files), logged=tuple(collect.records), rows_ahead=rows)
    except Exception as exc:  # the parent draws again, and reports it as it always did
        answer = PlotAnswer(None, f"{type(exc).__name__}: {exc}")
    with contextlib.suppress(OSError):
        _send(stdout, pickle.dumps(answer))
    return 0


def _job(stdin: IO[bytes]) -> tuple[PlotJob | StudyPlotJob, CsvAhead | None]:
    """The job from the process that started us, and the rows of results.csv formatted
    while its run went on when the first message asked to follow them (:mod:`.csvfollow`)."""
    message = pickle.loads(_receive(stdin))  # from the process that started us: trusted
    if not isinstance(message, FollowRows):
        return message, None
    from fmionnx.results.csvfollow import follow_until_readable

    ahead = follow_until_readable(message, stdin.fileno())
    return pickle.loads(_receive(stdin)), ahead


def _results_csv(job: PlotJob, ahead: CsvAhead) -> Drawing:
    """Writing ``results.csv`` as one of the job's drawings: the bytes the run's process
    would write (:func:`~fmionnx.results.csvfile.write_csv`, the same pieces check)."""
    from fmionnx.results.csvfile import write_csv

    aliases = dict(job.aliases) if job.aliases is not None else None

    def write() -> Path:
        return write_csv(job.result, job.out / "results.csv", aliases=aliases, ahead=ahead)

    return write


if __name__ == "__main__":
    # Run as the package's module, not as __main__: the answer's class must unpickle under
    # its own name in the parent.
    from fmionnx.results.plotworker import main as worker_main

    code = worker_main()
    sys.stderr.flush()
    os._exit(code)  # the answer is sent: no clean-up of matplotlib the parent would wait for
