"""``fmionnx run``'s checks table: every check of the system with its measured value.

The table goes to stderr beside the run summary (stdout keeps the last line, the results
folder). With ``--quiet`` only failed checks are printed, one line each: the exit code says
that a check failed, the line says which one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from fmionnx.runtime.checks import CheckOutcome


def failed(outcomes: Sequence[CheckOutcome]) -> list[CheckOutcome]:
    """The checks that did not hold."""
    return [o for o in outcomes if not o.passed]


def value_text(outcome: CheckOutcome) -> str:
    """The measured value for people: 4 significant digits, or why there is none.

    More digits where 4 would put the value on the wrong side of the bound, or on it: a
    ``mean(time) == 0.5`` measuring 0.49999999999999994 failed as "measured 0.5, expected
    == 0.5" (a bug hunt). Enough are shown to tell the value from the bound the way the
    check did, at most the value's shortest exact text."""
    value = outcome.value
    if value is None:
        return "—"
    if not math.isfinite(value) or not math.isfinite(outcome.bound):
        return f"{value:.4g}"
    side = _side(value, outcome.bound)
    for digits in range(4, 16):  # then exactly: 16 digits may be neither
        text = f"{value:.{digits}g}"
        if _side(float(text), outcome.bound) == side:
            return text
    return repr(value)


def bound_text(outcome: CheckOutcome) -> str:
    """The bound as the check compares with it: ``:g`` where that is the bound exactly, else
    its shortest exact text (``1234567`` is not ``1.23457e+06``)."""
    short = f"{outcome.bound:g}"
    return short if float(short) == outcome.bound else repr(outcome.bound)


def _check_text(outcome: CheckOutcome) -> str:
    """The check's name and, dimmed below it, its expression; an unnamed check is called by
    its expression, which shown twice ("max(g.y) > 0 / max(g.y) > 0") said nothing more (a
    bug hunt)."""
    name = escape(outcome.name)
    if outcome.name == outcome.expression:
        return name
    return f"{name}\n[dim]{escape(outcome.expression)}[/]"


def _side(value: float, bound: float) -> int:
    """Below (-1), on (0) or above (1) the bound."""
    return (value > bound) - (value < bound)


def print_checks(console: Console, outcomes: Sequence[CheckOutcome], *, quiet: bool) -> None:
    """The checks table (or, quietly, one line per failed check); nothing without checks."""
    if not outcomes:
        return
    bad = failed(outcomes)
    if quiet:
        for outcome in bad:
            console.print(
                f"[bold red]check failed:[/] {escape(outcome.name)}: {verdict_text(outcome)}"
            )
        return
    table = Table(title="checks", title_justify="left")
    table.add_column("check", overflow="fold", ratio=1)
    table.add_column("measured", overflow="fold")
    table.add_column("expected", no_wrap=True)
    table.add_column("result", no_wrap=True)
    for outcome in outcomes:
        verdict = "[green]pass[/]" if outcome.passed else "[bold red]FAIL[/]"
        note = f"\n[yellow]{escape(outcome.note)}[/]" if outcome.note else ""
        table.add_row(
            f"{_check_text(outcome)}{note}",
            value_text(outcome),
            f"{outcome.comparison} {bound_text(outcome)}",
            verdict,
        )
    console.print(table)
    if bad:
        console.print(f"[bold red]{len(bad)} of {len(outcomes)} checks failed[/]")
    else:
        console.print(f"[green]all {len(outcomes)} checks passed[/]")


def verdict_text(outcome: CheckOutcome) -> str:
    """Why a check failed, in one phrase: the note, or the value against the bound."""
    expected = f"{outcome.comparison} {bound_text(outcome)}"
    measured = f"measured {value_text(outcome)}, expected {expected}"
    return escape(outcome.note) if outcome.value is None and outcome.note else measured
