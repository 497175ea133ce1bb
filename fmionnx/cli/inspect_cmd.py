"""``fmionnx inspect``: show what a model file offers (ports and facts), without a system file.

Every text shown comes from the model file (names, descriptions, units, metadata): its control
characters are shown escaped (:func:`~fmionnx.core.printable.printable`), so a hostile model
cannot send escape sequences to the terminal, nor break a table row with a line break. The
JSON keeps the texts as they are (the encoder escapes them).
"""

from __future__ import annotations

import enum
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from fmionnx.cli.app import ExitCode, app
from fmionnx.core import codes
from fmionnx.core.codes import ErrorCode
from fmionnx.core.printable import printable

if TYPE_CHECKING:
    from fmionnx.core.types import ComponentInterface, Port

#: Columns of the port table, in order.
COLUMNS = ("name", "causality", "type", "shape", "unit", "start", "range", "description")

#: Start values longer than this are shortened in the table (the JSON has them all).
_MAX_START_VALUES = 6


class InspectFormat(enum.StrEnum):
    """Output formats of ``inspect``."""

    TEXT = "text"
    JSON = "json"


def _start_text(port: Port) -> str:
    if port.start is None:
        return ""
    values = [f"{v:g}" if isinstance(v, float) else str(v) for v in port.start]
    if port.is_scalar and len(values) == 1:
        return values[0]
    shown = values[:_MAX_START_VALUES]
    more = ", ..." if len(values) > _MAX_START_VALUES else ""
    return "[" + ", ".join(shown) + more + "]"


def _range_text(port: Port) -> str:
    """The declared bounds: ``0..14``, ``>= 0``, ``<= 13`` or nothing."""
    low, high = (None if b is None else f"{b:g}" for b in port.bounds)
    if low is not None and high is not None:
        return f"{low}..{high}"
    if low is not None:
        return f">= {low}"
    return "" if high is None else f"<= {high}"


def shown_columns(interface: ComponentInterface) -> tuple[str, ...]:
    """:data:`COLUMNS`, without ``range`` when no port declares bounds (most models: a column
    empty on every row says nothing)."""
    if any(port.bounds != (None, None) for port in interface.ports):
        return COLUMNS
    return tuple(c for c in COLUMNS if c != "range")


def port_rows(interface: ComponentInterface) -> list[tuple[str, ...]]:
    """One row of :func:`shown_columns` per port, each cell printable (one line, no escape
    sequence)."""
    ranged = "range" in shown_columns(interface)
    rows = [
        (
            port.name,
            port.causality.value,
            port.dtype.value,
            port.shape_text(),
            port.unit or "",
            _start_text(port),
            *((_range_text(port),) if ranged else ()),
            port.description,
        )
        for port in interface.ports
    ]
    return [tuple(printable(cell) for cell in row) for row in rows]


def fact_rows(interface: ComponentInterface) -> list[tuple[str, str]]:
    """The facts (and the content hash) as printable key/value pairs."""
    facts = [(printable(key), printable(value)) for key, value in interface.facts]
    if interface.content_hash:
        facts.append(("sha256", interface.content_hash))
    return facts


def _heading(interface: ComponentInterface) -> tuple[str, str]:
    return printable(interface.kind), printable(str(interface.path))


def render_plain(interface: ComponentInterface) -> str:
    """Aligned plain text for pipes and files: facts, then the port table."""
    kind, path = _heading(interface)
    lines = [f"{kind}: {path}"]
    facts = fact_rows(interface)
    width = max((len(k) for k, _ in facts), default=0)
    lines += [f"  {key.ljust(width)}  {value}" for key, value in facts]
    columns = shown_columns(interface)
    rows = [tuple(c.upper() for c in columns), *port_rows(interface)]
    widths = [max(len(row[i]) for row in rows) for i in range(len(columns))]
    lines.append("")
    lines += [
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in rows
    ]
    return "\n".join(lines) + "\n"


def render_rich(interface: ComponentInterface, console: Console) -> None:
    """The same content as :func:`render_plain` with a rich table, for terminals."""
    kind, path = _heading(interface)
    console.print(f"[bold]{escape(kind)}[/]: {escape(path)}")
    facts = Table.grid(padding=(0, 2))
    for key, value in fact_rows(interface):
        facts.add_row(Text("  " + key, style="dim"), Text(value))
    console.print(facts)
    table = Table(box=box.SIMPLE_HEAD, header_style="bold")
    for column in shown_columns(interface):
        table.add_column(column, overflow="fold")
    for row in port_rows(interface):
        table.add_row(*(Text(cell) for cell in row))
    console.print(table)


def _fail(code: ErrorCode | None, message: str, hint: str | None = None) -> typer.Exit:
    """``error[Exxx]: message`` on stderr; the message may quote the model: printable."""
    err = Console(stderr=True, highlight=False)
    label = f"error[{code.code}]" if code else "error"
    err.print(f"[bold red]{label}[/]: {escape(printable(message))}", soft_wrap=True)
    if hint:
        err.print(f"  hint: {printable(hint)}", markup=False, soft_wrap=True)
    return typer.Exit(ExitCode.PROBLEMS)


@app.command(
    epilog="Examples:\n\n"
    "  fmionnx inspect build/models/ReadOdometry.fmu\n\n"
    "  fmionnx inspect build/models/sign_detector.onnx --format json\n\n"
    "  fmionnx inspect models/world/sign_course.xml   # a MuJoCo scene\n\n"
    "  fmionnx inspect path/to/unpacked_fmu/",
)
def inspect(
    path: Annotated[
        Path, typer.Argument(help="Model file: .fmu (or unpacked FMU folder), .onnx, MuJoCo .xml.")
    ],
    output_format: Annotated[
        InspectFormat, typer.Option("--format", "-f", help="text (default) or json.")
    ] = InspectFormat.TEXT,
) -> None:
    """Show a model's ports (name, causality, type, shape, unit, start) and facts."""
    from fmionnx.core.errors import ModelError
    from fmionnx.kinds.describe import interface_to_dict
    from fmionnx.kinds.registry import COMPONENT_KINDS, kind_for_path, model_root

    path = model_root(path)  # an unpacked FMU's description names the FMU, not a scene
    kind = kind_for_path(path)
    if kind is None:
        if not path.exists():
            raise _fail(codes.FILE_NOT_FOUND, f"`{path}` does not exist")
        suffixes = sorted({s for k in COMPONENT_KINDS.values() for s in k.suffixes})
        raise _fail(
            codes.UNKNOWN_KIND,
            f"cannot tell what kind of model `{path}` is",
            f"expected a file ending in {', '.join(suffixes)} or an unpacked FMU folder",
        )
    try:
        interface = kind.read_interface(path, None)
    except ModelError as exc:
        raise _fail(exc.code, str(exc), exc.hint) from None
    if output_format is InspectFormat.JSON:
        sys.stdout.write(json.dumps(interface_to_dict(interface), indent=2) + "\n")
    elif sys.stdout.isatty():
        render_rich(interface, Console(highlight=False))
    else:
        sys.stdout.write(render_plain(interface))
