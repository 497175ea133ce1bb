"""What a run through the pipeline gives back: its result, checks, files and exit status."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from fmionnx.pipeline.errors import EXIT_OK, EXIT_PROBLEMS
from fmionnx.runtime.checks import CheckOutcome
from fmionnx.runtime.result import RunResult, RunStatus

if TYPE_CHECKING:
    from fmionnx.pipeline.system import System


@dataclass(frozen=True)
class RunOutcome:
    """One finished run: the signals (``outcome["comp.port"]``, named as in results.csv), the
    verdict of every check, the files written and the exit status ``fmionnx run`` gives.

    The exit status: 0 completed with every check passed; 1 a fault or a failed check (the
    results are written either way: a failed check is a verdict, not a crash); 130 or 143
    when a stop signal interrupted the run.
    """

    system: System
    result: RunResult
    checks: tuple[CheckOutcome, ...]
    files: tuple[Path, ...]
    out: Path | None
    exit_status: int

    @property
    def status(self) -> RunStatus:
        """How the run ended."""
        return self.result.status

    @property
    def passed(self) -> bool:
        """Whether every evaluated check passed."""
        return all(check.passed for check in self.checks)

    def __getitem__(self, name: str) -> npt.NDArray[np.float64]:
        """A recorded signal by its results.csv column name (``time`` too)."""
        return self.result[name]


def exit_status(result: RunResult, checks: tuple[CheckOutcome, ...]) -> int:
    """The exit status of a run that ended as ``result`` with ``checks`` evaluated."""
    from fmionnx.runtime.stopping import exit_code

    if result.status is RunStatus.FAULT:
        return EXIT_PROBLEMS
    if result.status is RunStatus.INTERRUPTED:
        return exit_code(result.interrupted_by)
    if not all(check.passed for check in checks):
        return EXIT_PROBLEMS
    return EXIT_OK
