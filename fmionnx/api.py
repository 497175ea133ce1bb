"""The Python API: everything the CLI does, callable from code and tests.

    >>> import fmionnx
    >>> outcome = fmionnx.run("systems/sign_follower.yaml", stop_time=5.0, no_out=True)
    >>> outcome["odometry.posX"][-1], outcome.status, outcome.exit_status

    >>> system = fmionnx.load("systems/sign_follower.yaml")
    >>> result = system.run(stop_time=5.0, backend="ros2", middleware="zenoh")

    >>> from fmionnx import api
    >>> checked = api.compile_system("systems/sign_follower.yaml")
    >>> checked.ok, [str(d.span) for d in checked.diagnostics]

``run`` and ``System.run`` take every ``fmionnx run`` option under its flag's name in
snake_case and go through the same run pipeline (:mod:`fmionnx.pipeline`), with the same
defaults (FMUs isolated). A single FMU's results are named by variable (``result["x"]``),
like ``fmpy simulate``. ``load`` accepts a system file (YAML/SSP), a compiled system
(``*.fmionnx.json``) or a single model.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Unpack

from fmionnx.compile.overrides import OverrideError, parse_value
from fmionnx.pipeline.errors import PipelineError, RefusedError, RequestError
from fmionnx.pipeline.request import COMPILED_SUFFIX, RunSettings
from fmionnx.pipeline.system import (
    MODEL_SUFFIXES,
    CompileResult,
    System,
    check_model,
    check_study,
    compile_system,
    is_model_file,
    is_study_file,
    load,
)

if TYPE_CHECKING:  # numpy and the runtime load when a system runs, not for `validate` / `--help`
    from collections.abc import Mapping

    import numpy as np
    import numpy.typing as npt
    import pandas as pd

    from fmionnx.pipeline.outcome import RunOutcome
    from fmionnx.pipeline.run import SignalNames
    from fmionnx.pipeline.sweep import SweepProgress

__all__ = [
    "COMPILED_SUFFIX",
    "MODEL_SUFFIXES",
    "CompileResult",
    "OverrideError",
    "PipelineError",
    "RefusedError",
    "RequestError",
    "RunSettings",
    "System",
    "check_model",
    "check_study",
    "compile_system",
    "is_model_file",
    "is_study_file",
    "load",
    "parse_value",
    "run",
    "run_onnx_once",
    "sweep",
]


def run(
    target: str | Path | System,
    /,
    *,
    signals: SignalNames | None = None,
    **settings: Unpack[RunSettings],
) -> RunOutcome:
    """Run ``target`` (a path or a loaded System) as ``fmionnx run`` would: every option by
    its flag's name in snake_case, the same defaults, results in ``out/<system name>/``
    unless ``out=`` or ``no_out=True`` (:func:`fmionnx.pipeline.run.run`); ``signals``
    (``("gain.y",)``) narrows what is recorded. A single ``.onnx`` model is inferred once,
    as ``fmionnx run model.onnx --input name=file.npy`` does: its outcome's ``outputs``."""
    from fmionnx.pipeline.run import run as run_target

    return run_target(target, signals=signals, **settings)


def run_onnx_once(
    system: System, inputs: Mapping[str, npt.ArrayLike]
) -> dict[str, npt.NDArray[np.generic]]:
    """Run a one-ONNX-model system once on ``inputs``; returns outputs shaped like the model's."""
    from fmionnx.pipeline.infer import run_onnx_once as infer_once

    return infer_once(system, inputs)


def sweep(
    study: str | Path,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    resume: bool = False,
    keep_results: bool = False,
    force: bool = False,
    progress: SweepProgress | None = None,
    batch: int | None = None,
    rrd: bool = False,
    client: Any = None,
) -> pd.DataFrame:
    """Run a study file's cases (``fmionnx sweep``) and return its table, one row per case.

    ``scheduler`` is an existing Dask cluster (``tcp://host:8786``), whose client this process
    keeps for its next studies; ``client`` a Dask ``distributed.Client`` of the caller's (a
    cluster kept warm for many studies: its workers keep what they loaded), left open;
    without either a local cluster of ``workers`` processes (default: one per core) runs the
    cases and ends with the study. Results go to
    ``out`` (docs/sweep.md); ``resume`` finishes an interrupted study there, ``force``
    replaces an earlier study's results there; ``rrd`` keeps each case's Rerun recording
    (``cases/<id>/run.rrd``). ``batch`` fixes the cases per Dask task (1: one
    each; default: short cases are batched by their measured time). Raises
    DiagnosticError for a study (or system) file with errors, before anything runs.
    A script calling it must do so under ``if __name__ == "__main__":``: the local cluster's
    workers import the script again (called from one of them, it raises ClusterStartError).
    """
    from fmionnx.backends.sweep.engine import refuse_in_starting_worker
    from fmionnx.pipeline.sweep import sweep_study

    refuse_in_starting_worker()
    result = sweep_study(
        study, Path(out), scheduler=scheduler, workers=workers, resume=resume,
        keep_results=keep_results, force=force, progress=progress, batch=batch, rrd=rrd,
        client=client,
    )  # fmt: skip
    return result.table
