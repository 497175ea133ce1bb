"""The system file's ``record:`` list resolved to ports, each one a port the run can record.

``results.csv`` and every other consumer of the recorded rows hold numbers, one float64 (or,
exactly, one 64-bit integer) per column and base step. A string or binary port has no such
value: its ``record:`` entry was left out of the results without a word (a bug hunt). It is
refused here instead, at the entry, with E025; the default recording (no ``record:``) leaves
such ports out, as docs/running.md says.
"""

from __future__ import annotations

from fmionnx.compile.endpoints import resolve_endpoint
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note
from fmionnx.core.types import Component, ComponentInterface, DType, PortRef
from fmionnx.spec.sourcemap import SourceMap

#: Element types no results column holds.
UNRECORDABLE = (DType.STRING, DType.BINARY)


def recorded_refs(
    texts: list[str],
    components: dict[str, Component],
    unreadable: frozenset[str],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> list[PortRef]:
    """The ports ``record:`` names (E02x for unknown ones, E025 for unrecordable types)."""
    interfaces: dict[str, ComponentInterface | None] = {
        **dict.fromkeys(unreadable),
        **{n: c.interface for n, c in components.items()},
    }
    refs = []
    for index, text in enumerate(texts):
        span = sources.value(("record", index))
        resolved = resolve_endpoint(text, span, interfaces, bag)
        if resolved is None:
            continue
        port = resolved.port
        if port.dtype in UNRECORDABLE:
            origin = port.origin
            bag.emit(
                codes.UNSUPPORTED_VARIABLE,
                f"`{resolved.ref}` is a {port.dtype} port: results hold numbers, and "
                f"{port.dtype} values are not recorded",
                span,
                hint="remove it from `record:`",
                notes=[Note(f"`{port.name}` is declared at {origin}")] if origin else [],
            )
            continue
        refs.append(resolved.ref)
    return refs
