"""The system file's ``record:`` list resolved to ports, each one a port the run can record.

``results.csv`` and every other consumer of the recorded rows hold numbers, one float64 (or,
exactly, one 64-bit integer) per column and base step. A string or binary port has no such
value: its ``record:`` entry was left out of the results without a word (a bug hunt). It is
refused here instead, at the entry, with E025; the default recording (no ``record:``) leaves
such ports out, as docs/running.md says.

An image (:func:`~fmionnx.core.signals.is_image`: a camera's ``uint8[H,W,3]``, an ONNX
``uint8`` tensor of two or more dimensions) was left out the same way, whole or by element:
the recorder takes no image (a 640x480 camera would be 921,600 columns a row, and a camera's
buffer holds a frame only when a component reads it). It is E025 too, naming where frames
are kept instead: MCAP and Rerun recordings, as they are rendered (docs/viewing.md).
"""

from __future__ import annotations

from fmionnx.compile.endpoints import resolve_endpoint
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span
from fmionnx.core.signals import is_image
from fmionnx.core.types import Component, ComponentInterface, DType, Port, PortRef
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
    """The ports ``record:`` names (E02x for unknown ones, E025 for strings, binaries and
    images, which the recorder does not keep)."""
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
        if _recordable(resolved.ref, resolved.port, span, bag):
            refs.append(resolved.ref)
    return refs


def _recordable(ref: PortRef, port: Port, span: Span | None, bag: DiagnosticBag) -> bool:
    """Whether the recorder keeps ``port`` (E025 at the entry if not: never dropped silently)."""
    origin = port.origin
    notes = [Note(f"`{port.name}` is declared at {origin}")] if origin else []
    if port.dtype in UNRECORDABLE:
        bag.emit(
            codes.UNSUPPORTED_VARIABLE,
            f"`{ref}` is a {port.dtype} port: results hold numbers, and {port.dtype} values "
            "are not recorded",
            span,
            hint="remove it from `record:`",
            notes=notes,
        )
        return False
    if is_image(port):
        what = "an element of an image" if ref.index is not None else "an image"
        bag.emit(
            codes.UNSUPPORTED_VARIABLE,
            f"`{ref}` is {what} port ({port.dtype}{port.shape_text()}): images are not "
            "recorded in results",
            span,
            hint="remove it from `record:`: results keep numeric scalar and array ports; a "
            "camera's frames go to `fmionnx run --record FILE.mcap` or `--rrd FILE` as they "
            "are rendered",
            notes=notes,
        )
        return False
    return True
