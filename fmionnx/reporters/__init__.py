"""Renderers of diagnostics, by ``--format`` name."""

from __future__ import annotations

from collections.abc import Mapping

from fmionnx.reporters.base import FileResult, Reporter
from fmionnx.reporters.text import TextReporter

REPORTER_BY_NAME: Mapping[str, Reporter] = {
    "text": TextReporter(),
}

__all__ = ["REPORTER_BY_NAME", "FileResult", "Reporter"]
