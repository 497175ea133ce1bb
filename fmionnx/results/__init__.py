"""What a run leaves behind: ``results.csv``, ``run.json``, plots and an MCAP recording.

Writers take a :class:`~fmionnx.runtime.result.RunResult` (plus the compiled system for plot
definitions and provenance) and never re-run anything; a faulted or interrupted run writes
exactly what it recorded.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.compile.ir import CompiledSystem
from fmionnx.runtime.result import RunResult


def write_results(
    result: RunResult,
    system: CompiledSystem,
    out: Path,
    *,
    aliases: dict[str, str] | None = None,
) -> list[Path]:
    """Write results.csv, run.json and the system's plots into ``out``; returns the files."""
    from fmionnx.results.csvfile import write_csv
    from fmionnx.results.plots import write_plots
    from fmionnx.results.runinfo import write_run_json

    out.mkdir(parents=True, exist_ok=True)
    files = [write_csv(result, out / "results.csv", aliases=aliases)]
    files.append(write_run_json(result, system, out / "run.json"))
    files.extend(write_plots(result, system, out))
    return files
