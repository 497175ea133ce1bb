"""``run.json``: what ran, how it ended, how fast, with which library versions."""

from __future__ import annotations

import json
import platform
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from fmionnx import __version__
from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.safewrite import write_text_atomic
from fmionnx.kinds.registry import KIND_LIBRARIES
from fmionnx.runtime.checks import CheckOutcome
from fmionnx.runtime.result import RunResult

#: Distributions whose versions make a run reproducible: each kind's libraries, and numpy.
VERSIONED = (*(lib for libraries in KIND_LIBRARIES.values() for lib in libraries), "numpy")


def versions() -> dict[str, str]:
    """fmionnx and the versions of the simulation libraries installed."""
    found = {"fmionnx": __version__, "python": platform.python_version()}
    for name in VERSIONED:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "not installed"
    return found


def run_info(
    result: RunResult,
    system: CompiledSystem,
    files: list[str] | None = None,
    checks: Sequence[CheckOutcome] = (),
) -> dict[str, Any]:
    """The run.json document; ``files`` names what the run wrote into its folder, ``checks``
    the verdicts of the system's checks."""
    error = result.error
    return {
        "system": system.name,
        "source": system.source.name,
        "content_hash": system.content_hash,
        "backend": result.backend,
        "status": result.status.value,
        "interrupted_by": result.interrupted_by,
        "ended_by": None if result.ended_by is None else result.ended_by.as_dict(),
        "start_time": result.start,
        "stop_time": result.stop,
        "step": result.step,
        "output_interval": system.run.output_interval,
        "steps": result.steps_done,
        "simulated_time": result.simulated_time,
        "wall_time": round(result.wall_time, 6),
        "real_time_factor": round(result.real_time_factor, 3) if result.wall_time > 0 else None,
        "settings_origin": {key: origin.value for key, origin in system.run.origins},
        "error": None
        if error is None
        else {
            "message": str(error),
            "component": error.component,
            "port": error.port,
            "time": error.time,
        },
        "execution": dict(result.details),
        "warnings": list(result.warnings),
        "statistics": result.statistics,
        "pacing": result.pacing,
        "checks": [outcome.as_json() for outcome in checks],
        "columns": ["time", *result.signals],
        "versions": versions(),
        **({} if files is None else {"files": sorted(files)}),
    }


def write_run_json(
    result: RunResult,
    system: CompiledSystem,
    path: Path,
    *,
    files: list[str] | None = None,
    checks: Sequence[CheckOutcome] = (),
) -> Path:
    """Write run.json (indented, keys in a fixed order; atomically, never through a link)."""
    document = run_info(result, system, files, checks)
    return write_text_atomic(path, json.dumps(document, indent=2) + "\n")
