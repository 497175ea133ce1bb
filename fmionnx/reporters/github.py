"""``--format github``: GitHub Actions workflow commands, shown inline on pull requests.

Each diagnostic becomes ``::error file=F,line=L,col=C,title=E031 dtype::message``; warnings
use ``::warning`` and infos ``::notice``. Escaping follows the runner's rules (the
``@actions/core`` toolkit): in the message ``%``, CR and LF are percent-encoded; in property
values ``:`` and ``,`` are too. Notes and hints follow the message on their own lines, so the
annotation shows the whole story. Every text is printable first
(:func:`~fmionnx.core.printable.printable`): a control character quoted from a model file is
shown escaped, in the log and in the annotation, and a line break in it cannot end the command.
"""

from __future__ import annotations

from typing import TextIO

from fmionnx.core.diagnostics import Diagnostic, Severity
from fmionnx.core.printable import printable
from fmionnx.reporters.base import FileResult, Reporter
from fmionnx.reporters.common import capped, detail_lines, display_path, left_out, located
from fmionnx.reporters.text import summary

_COMMAND = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.INFO: "notice"}


def escape_data(text: str) -> str:
    """Escape the message part of a workflow command."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def escape_property(text: str) -> str:
    """Escape a property value (``file=``, ``title=`` ...) of a workflow command."""
    return escape_data(text).replace(":", "%3A").replace(",", "%2C")


def annotation(diagnostic: Diagnostic, result: FileResult) -> str:
    """The workflow command line of one diagnostic."""
    span = located(diagnostic, result.path)
    properties = [("file", display_path(span.file))]
    if span.line > 0:
        properties.append(("line", str(span.line)))
        if span.col > 0:
            properties.append(("col", str(span.col)))
    properties.append(("title", f"{diagnostic.code} {diagnostic.name}"))
    props = ",".join(f"{key}={escape_property(printable(value))}" for key, value in properties)
    # Message, notes and hint on their own lines (the only line breaks the text keeps).
    text = "\n".join(printable(part) for part in [diagnostic.message, *detail_lines(diagnostic)])
    return f"::{_COMMAND[diagnostic.severity]} {props}::{escape_data(text)}"


class GithubReporter(Reporter):
    """One workflow command per diagnostic (at most :data:`~.common.SHOWN_PER_CODE` of a
    code per file), then the plain summary line for the log."""

    name = "github"

    def render(self, results: list[FileResult], stream: TextIO, *, color: bool) -> None:
        """Write annotations (never coloured: the runner parses them)."""
        del color
        for result in results:
            for diagnostic in capped(result.diagnostics):
                if isinstance(diagnostic, tuple):  # a plain log line, not an annotation
                    stream.write(left_out(*diagnostic) + "\n")
                    continue
                stream.write(annotation(diagnostic, result) + "\n")
        stream.write(summary(results) + "\n")
