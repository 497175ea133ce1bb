"""Compiler-style text output: ``file:line:col: error[E031 dtype]: ...`` with the source line.

Messages quote the files they are about (a port name of an ONNX model, a file name): every
line is printable (:func:`~fmionnx.core.printable.printable`), its control characters shown
escaped, so a hostile model sends no escape sequence to the terminal.
"""

from __future__ import annotations

from typing import TextIO

from rich.console import Console
from rich.markup import escape

from fmionnx.core.diagnostics import Diagnostic, Severity, Span
from fmionnx.core.printable import printable
from fmionnx.core.sourcetext import source_lines
from fmionnx.reporters.base import FileResult, Reporter, count
from fmionnx.reporters.common import capped, left_out

_STYLE = {Severity.ERROR: "bold red", Severity.WARNING: "bold yellow", Severity.INFO: "bold cyan"}


def source_excerpt(span: Span) -> list[str]:
    """The source line of ``span`` and a caret under its column (empty when unknown)."""
    if span.line <= 0:
        return []
    lines = source_lines(span.file)
    if span.line > len(lines):
        return []
    text = lines[span.line - 1].expandtabs(1)
    gutter = f"{span.line:>4} | "
    excerpt = [gutter + printable(text)]
    if span.col > 0:  # under the column as shown: an escaped character before it is wider
        before = len(printable(text[: span.col - 1])) + max(0, span.col - 1 - len(text))
        excerpt.append(" " * (len(gutter) - 2) + "| " + " " * before + "^")
    return excerpt


def format_plain(diagnostic: Diagnostic, *, excerpt: bool = True) -> list[str]:
    """The lines of one diagnostic without colour (golden files use this), each printable."""
    where = f"{diagnostic.span}: " if diagnostic.span else ""
    head = f"{where}{diagnostic.severity.label}[{diagnostic.code} {diagnostic.name}]: {diagnostic.message}"
    lines = [printable(head)]
    if excerpt and diagnostic.span is not None:
        lines.extend(source_excerpt(diagnostic.span))
    for note in diagnostic.notes:
        at = f"{note.span}: " if note.span else ""
        lines.append(printable(f"  note: {at}{note.message}"))
    if diagnostic.hint:
        lines.append(printable(f"  hint: {diagnostic.hint}"))
    return lines


def summary(results: list[FileResult]) -> str:
    """``2 errors, 1 warning in 2 files (3 checked)`` (``no problems in 1 file``).

    The files counted with problems are those the problems point at: a study's errors in its
    system file were "in 1 file" (the one checked)."""
    errors = count(results, Severity.ERROR)
    warnings = count(results, Severity.WARNING)
    if not errors and not warnings:
        return f"no problems in {_files(len(results))}"
    where = {
        d.span.file if d.span is not None else r.path
        for r in results
        for d in r.diagnostics
        if d.severity in (Severity.ERROR, Severity.WARNING)
    }
    files = _files(len(where))
    if len(results) > len(where):
        files += f" ({len(results)} checked)"
    parts = []
    if errors:
        parts.append(f"{errors} error" + ("s" if errors != 1 else ""))
    if warnings:
        parts.append(f"{warnings} warning" + ("s" if warnings != 1 else ""))
    return ", ".join(parts) + f" in {files}"


class TextReporter(Reporter):
    """Human-readable report; colour and bold only on a terminal."""

    name = "text"

    def render(self, results: list[FileResult], stream: TextIO, *, color: bool) -> None:
        """Write the diagnostics (at most :data:`~.common.SHOWN_PER_CODE` of one code per
        file, then a line counting the others), then a one-line summary of all."""
        console = Console(
            file=stream, force_terminal=color, no_color=not color, highlight=False, soft_wrap=True
        )
        for result in results:
            for diagnostic in capped(result.diagnostics):
                if isinstance(diagnostic, tuple):
                    console.print(escape(left_out(*diagnostic)), style="bold")
                    continue
                lines = format_plain(diagnostic)
                style = _STYLE[diagnostic.severity]
                label = f"{diagnostic.severity.label}[{diagnostic.code} {diagnostic.name}]"
                console.print(
                    escape(lines[0]).replace(escape(label), f"[{style}]{escape(label)}[/]", 1)
                )
                for line in lines[1:]:
                    console.print(escape(line), style="dim" if "|" in line[:8] else None)
        errors = count(results, Severity.ERROR)
        style = "bold red" if errors else "bold green"
        console.print(summary(results), style=style)


def _files(number: int) -> str:
    return f"{number} file" + ("s" if number != 1 else "")
