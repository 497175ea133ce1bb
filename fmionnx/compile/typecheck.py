"""Per-connection checks: causality, element type, element count (units: :mod:`unitcheck`).

The allowed conversions are data (:data:`LOSSLESS`), documented in ``docs/types.md``:
numeric types convert into each other (bool as 0/1); float -> integer or bool, integer
narrowing and integer -> float where the float's significand is narrower than the integer
(int64 -> float64, int32 -> float32) are allowed with a warning (W031); strings and binaries
connect to no other type (E031), and to their own not yet (E025: :data:`UNCONNECTABLE`).
"""

from __future__ import annotations

from fmionnx.compile.endpoints import ResolvedEndpoint, endpoint_text
from fmionnx.compile.symdims import UNSIZED
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span, with_article
from fmionnx.core.types import Causality, DType, Port, PortRef

_INT_BITS = {
    DType.INT8: (True, 8),
    DType.INT16: (True, 16),
    DType.INT32: (True, 32),
    DType.INT64: (True, 64),
    DType.UINT8: (False, 8),
    DType.UINT16: (False, 16),
    DType.UINT32: (False, 32),
    DType.UINT64: (False, 64),
}

#: Element types no connection carries yet (E025): the run's buffers, the native kernel, the
#: isolated FMUs' shared memory and the ROS 2 messages all hold numbers; strings and binaries
#: are set once, at setup (docs/types.md, docs/decisions.md).
UNCONNECTABLE = (DType.STRING, DType.BINARY)

#: Significand bits of each float type (the implicit leading bit included): every integer of
#: at most this many bits (sign apart) is held exactly, a wider one is rounded (IEEE 754).
SIGNIFICAND_BITS = {DType.FLOAT64: 53, DType.FLOAT32: 24}

SOURCE_CAUSALITIES = (Causality.OUTPUT,)
TARGET_CAUSALITIES = (Causality.INPUT,)


def is_lossy(source: DType, target: DType) -> bool:
    """True when converting ``source`` to ``target`` may lose values (float64->float32 is not).

    float64 -> float32 counts as exact by decision (docs/decisions.md): it is how every ONNX
    model takes FMU values. An integer into a float is exact only when the float's significand
    holds all the integer's magnitude bits: int64 -> float64 rounds 10**18 + 1 silently.
    """
    if source == target:
        return False
    if target.is_float:
        return source.is_integer and _int_to_float_rounds(source, target)
    if source.is_float:
        return True  # float -> integer or bool truncates
    if target is DType.BOOL:
        return source is not DType.BOOL
    if source is DType.BOOL:
        return False
    src_signed, src_bits = _INT_BITS[source]
    dst_signed, dst_bits = _INT_BITS[target]
    if src_signed and not dst_signed:
        return True
    return dst_bits < src_bits + (1 if dst_signed and not src_signed else 0)


def _int_to_float_rounds(source: DType, target: DType) -> bool:
    """Whether some value of integer ``source`` has no exact ``target`` float."""
    signed, bits = _INT_BITS[source]
    return bits - (1 if signed else 0) > SIGNIFICAND_BITS[target]


def _lossy_hint(source: DType, target: DType) -> str:
    """What the lossy conversion does to a value, said so that the reader can judge it."""
    if source.is_integer and target.is_float:
        limit = 2 ** SIGNIFICAND_BITS[target]
        return (
            f"an integer larger in magnitude than 2^{SIGNIFICAND_BITS[target]} ({limit}) may "
            f"be rounded to the nearest {target}; convert in the model, or accept the rounding"
        )
    return "convert in the model, or accept the truncation"


def declared_note(port: Port) -> list[Note]:
    """A note pointing at the port's declaration in its model file.

    A declaration inside an archive (``Gain.fmu/modelDescription.xml``) is no file anyone
    can open, so it is named in the text instead of given as a location.
    """
    origin = port.origin
    if origin is None:
        return []
    if origin.file.is_file():
        return [Note(f"`{port.name}` is declared here", origin)]
    return [Note(f"`{port.name}` is declared at {origin}")]


def check_causality(
    src: ResolvedEndpoint, dst: ResolvedEndpoint, span: Span, bag: DiagnosticBag
) -> bool:
    """Output -> input only; parameters are set under ``parameters:``, not by connections.

    A connection written backwards (an input to an output) is one mistake and one error,
    whose hint shows the connection turned round.
    """
    if src.port.causality is Causality.INPUT and dst.port.causality is Causality.OUTPUT:
        bag.emit(
            codes.CAUSALITY,
            f"the connection runs backwards: `{src.ref}` is an input and `{dst.ref}` an "
            "output; a connection goes from an output to an input",
            span,
            hint=f"swap the two sides: `{dst.ref} -> {src.ref}`",
            notes=[*declared_note(src.port), *declared_note(dst.port)],
        )
        return False
    ok = True
    if src.port.causality not in SOURCE_CAUSALITIES:
        hint = None
        bag.emit(
            codes.CAUSALITY,
            f"`{src.ref}` is {with_article(src.port.causality.value)}, but a connection must start at an output",
            span,
            hint=hint,
            notes=declared_note(src.port),
        )
        ok = False
    if dst.port.causality not in TARGET_CAUSALITIES:
        if dst.port.causality in (Causality.PARAMETER, Causality.STRUCTURAL_PARAMETER):
            hint = f"set it under `components.{dst.ref.component}.parameters`"
        else:
            hint = None
        bag.emit(
            codes.CAUSALITY,
            f"`{dst.ref}` is {with_article(dst.port.causality.value)}, but a connection must end at an input",
            span,
            hint=hint,
            notes=declared_note(dst.port),
        )
        ok = False
    return ok


def check_dtype(
    src: ResolvedEndpoint, dst: ResolvedEndpoint, span: Span, bag: DiagnosticBag
) -> bool:
    """Numeric types convert; strings/binaries need the same type. Lossy ones warn."""
    a, b = src.port.dtype, dst.port.dtype
    if a == b and a in UNCONNECTABLE:
        bag.emit(
            codes.UNSUPPORTED_VARIABLE,
            f"`{src.ref}` -> `{dst.ref}` connects {a} ports: {a} values cannot travel on a "
            "connection yet",
            span,
            hint=f"set `{dst.ref.port}` under `components.{dst.ref.component}.parameters` "
            "instead (strings and binaries are set once, at setup)",
            notes=declared_note(dst.port),
        )
        return False
    if a == b:
        return True
    if a.is_numeric and b.is_numeric:
        if is_lossy(a, b):
            bag.emit(
                codes.LOSSY_CONVERSION,
                f"`{src.ref}` ({a}) -> `{dst.ref}` ({b}) may lose precision or range",
                span,
                hint=_lossy_hint(a, b),
            )
        return True
    bag.emit(
        codes.DTYPE,
        f"cannot connect `{src.ref}` of type {a} to `{dst.ref}` of type {b}",
        span,
        hint="numeric types convert into each other; strings and binaries only to their own type",
        notes=declared_note(dst.port),
    )
    return False


def check_count(
    src: ResolvedEndpoint, dst: ResolvedEndpoint, span: Span, bag: DiagnosticBag
) -> int | None:
    """Element counts must agree (shapes may differ: ``[1,3]`` -> ``(3,)`` reshapes).

    Where both ends have symbolic shapes the count is not known from the two ports alone:
    the source's may be fixed by what its own inputs are fed. The connection is let through
    as :data:`~.symdims.UNSIZED`, for :func:`~.symdims.check_symbolic_dims` to size in
    dataflow order or refuse."""
    if src.count is not None and dst.count is not None:
        if src.count == dst.count:
            return src.count
        _count_error(src, dst, span, bag)
        return None
    known = src.count if src.count is not None else dst.count
    if known is None:
        return UNSIZED
    symbolic = dst.port if dst.count is None else src.port
    fixed = 1
    for dim in symbolic.shape:
        if isinstance(dim, int):
            fixed *= dim
    if known % fixed != 0:
        _count_error(src, dst, span, bag)
        return None
    return known


def _count_error(
    src: ResolvedEndpoint, dst: ResolvedEndpoint, span: Span, bag: DiagnosticBag
) -> None:
    def described(end: ResolvedEndpoint) -> str:
        if end.ref.index is not None:
            return "1 element"
        return f"{end.count} element{'s' if end.count != 1 else ''} ({end.port.shape_text()})"

    hint = None
    if src.ref.index is None and src.count and src.count > 1 and dst.count == 1:
        hint = f"select one element, e.g. `{_first_element(src.ref)}`"
    elif dst.ref.index is None and dst.count and dst.count > 1 and src.count == 1:
        hint = f"drive one element, e.g. `{_first_element(dst.ref)}`"
    bag.emit(
        codes.SHAPE,
        f"`{src.ref}` carries {described(src)} but `{dst.ref}` takes {described(dst)}",
        span,
        hint=hint,
    )


def _first_element(ref: PortRef) -> str:
    """``ref``'s first element as an endpoint is written (``p."12"[0]`` for a quoted port)."""
    return endpoint_text(PortRef(ref.component, ref.port, (0,)))
