"""What every reporter receives and implements."""

from __future__ import annotations

import abc
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from fmionnx.core.diagnostics import Diagnostic, Severity


@dataclass(frozen=True, slots=True)
class FileResult:
    """The diagnostics of one checked system file."""

    path: Path
    diagnostics: tuple[Diagnostic, ...]
    #: True when the interface lock was checked (``validate --locked``); reports that list
    #: the checks performed (JUnit) mark the lock check skipped otherwise.
    locked: bool = False
    #: What the file is: ``system``, ``study`` or ``model`` (a single model checked alone).
    #: Reports that list the checks performed (JUnit) skip the study check for the others.
    document: str = "system"

    @property
    def worst(self) -> Severity | None:
        """The most severe diagnostic's severity, or None when there are none."""
        return max((d.severity for d in self.diagnostics), default=None)


class Reporter(abc.ABC):
    """Renders the results of a ``validate`` call to a text stream."""

    name: str

    @abc.abstractmethod
    def render(self, results: list[FileResult], stream: TextIO, *, color: bool) -> None:
        """Write ``results`` to ``stream``; ``color`` only when the stream is a terminal."""


def count(results: list[FileResult], severity: Severity) -> int:
    """Number of diagnostics of ``severity`` across all files."""
    return sum(1 for r in results for d in r.diagnostics if d.severity is severity)
