"""Renderers of diagnostics, by ``--format`` name."""

from __future__ import annotations

from collections.abc import Mapping

from fmionnx.reporters.base import FileResult, Reporter
from fmionnx.reporters.github import GithubReporter
from fmionnx.reporters.json_report import JsonReporter
from fmionnx.reporters.junit import JunitReporter
from fmionnx.reporters.sarif import SarifReporter
from fmionnx.reporters.text import TextReporter

REPORTER_BY_NAME: Mapping[str, Reporter] = {
    "text": TextReporter(),
    "json": JsonReporter(),
    "github": GithubReporter(),
    "sarif": SarifReporter(),
    "junit": JunitReporter(),
}

__all__ = ["REPORTER_BY_NAME", "FileResult", "Reporter"]
