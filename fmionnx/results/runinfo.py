"""``run.json``: what ran, how it ended, how fast, with which library versions."""

from __future__ import annotations

import json
import math
import platform
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

from fmionnx import __version__
from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.safewrite import write_text_atomic
from fmionnx.core.types import Scalar, ValueSource
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


def _json_value(value: Scalar) -> Scalar:
    """A value as JSON holds it: non-finite floats as the strings ``nan``, ``inf``, ``-inf``."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def parameter_table(system: CompiledSystem) -> list[dict[str, Any]]:
    """Every parameter and start value the run sets, with its final value and its source.

    One entry per value set before initialization, in component order: ``name``
    (``component.port``), ``value`` (a number, string or boolean; a list for an array) and
    ``source`` (``system file``, ``ssv file``, ``ssp inline``, ``ssp annotation``, ``command
    line``, ``study``), as the compiled system carries them, overrides applied. System inputs
    that hold a value of their own follow, named as on the command line.
    """
    table: list[dict[str, Any]] = []
    for component in system.components:
        for parameter in component.parameters:
            values = [_json_value(v) for v in parameter.value]
            port = component.interface.port(parameter.port)
            scalar = port is None or not port.shape
            table.append(
                {
                    "name": f"{component.name}.{parameter.port}",
                    "value": values[0] if scalar and len(values) == 1 else values,
                    "source": parameter.source.value,
                }
            )
    for system_input in system.inputs:
        if system_input.value is not None:
            source = system_input.source or ValueSource.SYSTEM_FILE
            table.append(
                {
                    "name": system_input.name,
                    "value": _json_value(system_input.value),
                    "source": source.value,
                }
            )
    return table


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
        "parameters": parameter_table(system),
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
