"""What a run leaves behind: ``results.csv``, ``run.json``, plots and an MCAP recording.

Writers take a :class:`~fmionnx.runtime.result.RunResult` (plus the compiled system for plot
definitions and provenance) and never re-run anything; a faulted or interrupted run writes
exactly what it recorded.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.compile.ir import CompiledSystem
from fmionnx.runtime.checks import CheckOutcome
from fmionnx.runtime.result import RunResult

if TYPE_CHECKING:
    from fmionnx.results.csvahead import CsvAhead
    from fmionnx.results.plotworker import PlotWorker


def write_results(
    result: RunResult,
    system: CompiledSystem,
    out: Path,
    *,
    aliases: dict[str, str] | None = None,
    also: list[Path] | None = None,
    checks: Sequence[CheckOutcome] | None = None,
    checkpoint: bool = False,
    plot_signals: bool = False,
    ahead: CsvAhead | None = None,
    plotter: PlotWorker | None = None,
) -> list[Path]:
    """Write results.csv, the system's plots and run.json into ``out``; returns the files.

    ``run.json`` records the verdict of every check of the system: ``checks`` when the caller
    has evaluated them already (``run`` prints them too), else evaluated here.

    ``checkpoint=True`` writes the results so far while a run goes on (so that a run killed
    outright loses only its last seconds): results.csv and run.json only; plots cost more
    than the data, and checks judge a whole run, so both are left to the final write.

    ``plot_signals=True`` (``run --plot``) also draws every recorded signal into
    ``signals.png`` (:mod:`fmionnx.results.signals_plot`). A run that recorded nothing
    (:func:`nothing_recorded`) draws no plots: a figure of every signal marked as not
    recorded says less than the one warning logged instead.

    ``ahead``: rows of results.csv formatted while a guarded run went on
    (:mod:`fmionnx.results.csvahead`); the file's bytes are the same without it.

    ``plotter``: a plot worker started before the run (:mod:`fmionnx.results.plotworker`);
    it draws the plots while results.csv is written here, or writes results.csv too when it
    followed the run's rows (:mod:`fmionnx.results.csvfollow`). The files are the same
    without it.

    ``run.json`` is written last and lists every file of the run (``also``: files written
    by others, e.g. ``--record`` into ``out``); then the folder's ownership record is made to
    list those very files (:mod:`fmionnx.core.owned`), so the next run into ``out`` can prove
    which files were fmionnx's and removes those it does not write again (see ``outdir``).
    """
    from fmionnx.core.owned import OwnedFolder
    from fmionnx.results.csvfile import write_csv
    from fmionnx.results.outdir import RUN_JSON, relative_name
    from fmionnx.results.runinfo import write_run_json
    from fmionnx.runtime.checks import evaluate_checks

    out.mkdir(parents=True, exist_ok=True)
    owned = OwnedFolder(out)
    previous = owned.proven_names()
    # The plotting modules load only for a run that draws (issue #14), and a plot worker
    # draws while results.csv is written here (issue #32).
    job = None
    drawing = not checkpoint and bool(system.plots or plot_signals)
    if drawing and nothing_recorded(result):
        import logging

        logging.getLogger("fmionnx.results").warning(
            "plots: none drawn: the run stopped before its models gave a first value, so "
            "nothing was recorded"
        )
        drawing = False
    if drawing:
        from fmionnx.results.plotworker import PlotJob

        by_worker = plotter is not None and plotter.follows  # it formatted the rows ahead
        job = PlotJob(result, system, out, bool(system.plots), plot_signals, aliases, by_worker)
    submitted = job is not None and plotter is not None and plotter.submit(job)
    csv = out / "results.csv"
    csv_by_worker = submitted and job is not None and job.results_csv
    files = [] if csv_by_worker else [write_csv(result, csv, aliases=aliases, ahead=ahead)]
    if job is not None:
        from fmionnx.results.plotworker import draw_here

        drawn = plotter.collect() if submitted and plotter is not None else None
        if csv_by_worker:  # written there beside the figures, else here (the same bytes)
            if drawn is not None and csv in drawn:
                drawn.remove(csv)
                files.append(csv)
            else:
                files.append(write_csv(result, csv, aliases=aliases))
        files.extend(drawn if drawn is not None else draw_here(job))
    path = out / RUN_JSON
    listed = [*files, *(also or []), path]
    names = [name for p in listed if (name := relative_name(p, out)) is not None]
    if checkpoint:
        checks = ()
    elif checks is None:
        checks = evaluate_checks(system.checks, result)
    files.append(write_run_json(result, system, path, files=names, checks=checks))
    owned.remove(previous - set(names))  # only what the record proves: nothing else
    owned.record(listed)
    return files


def note_finished_files(out: Path, paths: Sequence[Path]) -> None:
    """Add those of ``paths`` that lie in ``out`` to its ownership record: files of the run
    that take their names only after ``run.json`` is written (``--rrd``: its live view
    renames the recording into place once the run has finished). ``run.json`` lists them
    already; unnoted, the next run into ``out`` could not prove them its own (a bug hunt)."""
    from fmionnx.core.owned import OwnedFolder

    OwnedFolder(out).note(paths)  # a path elsewhere, or no file there, is no entry


def nothing_recorded(result: RunResult) -> bool:
    """Whether ``result`` holds no value of any signal: the run stopped (a Ctrl-C, a model
    that hung or failed) before its models gave their first values. A run that recorded
    signals other than those plotted is drawn, with the missing ones named on the figure."""
    return not result.signals and result.steps_done == 0
