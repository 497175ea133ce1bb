"""Parse and resolve connection endpoints ``component.port[index]`` against real interfaces."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Note, Span, did_you_mean, one_of
from fmionnx.core.types import Causality, ComponentInterface, Port, PortRef
from fmionnx.spec.runspec import ENDPOINT_RE


@dataclass(frozen=True, slots=True)
class ResolvedEndpoint:
    """An endpoint resolved to its port; ``count`` elements flow through it."""

    ref: PortRef
    port: Port
    count: int | None


def split_endpoint(
    text: str, components: Mapping[str, object]
) -> tuple[str, str, str | None] | None:
    """Split ``a.b.c[2]`` into (component, port, index text) by the longest known component.

    Returns None when the text is not an endpoint at all. When no component name is a prefix,
    the component is the first dotted part (so the caller can report it as unknown).
    """
    match = ENDPOINT_RE.match(text)
    if match is None:
        return None
    name = match.group("name")
    index = match.group("index")
    best = ""
    for component in components:
        if name.startswith(component + ".") and len(component) > len(best):
            best = component
    if not best:
        best = name.split(".", 1)[0]
    return best, name[len(best) + 1 :], index


def resolve_endpoint(
    text: str,
    span: Span,
    interfaces: Mapping[str, ComponentInterface | None],
    bag: DiagnosticBag,
    *,
    role: Causality | None = None,
) -> ResolvedEndpoint | None:
    """Resolve one endpoint; report E020-E023 into ``bag`` and return None on failure.

    A component whose interface could not be read (``None``) makes its endpoints unresolvable
    without a further diagnostic: its own error was reported already. ``role``: the
    causality the endpoint needs (a connection's source is an output, its target an input);
    an unknown port's hint then suggests ports of that causality.
    """
    parts = split_endpoint(text, interfaces)
    if parts is None:
        bag.emit(
            codes.BAD_ENDPOINT,
            f"`{text.strip()}` is not an endpoint",
            span,
            hint="write `component.port`, or `component.port[i]` for one element",
        )
        return None
    component, port_name, index_text = parts
    if component not in interfaces:
        hint = did_you_mean(component, interfaces) or one_of(interfaces)
        bag.emit(
            codes.UNKNOWN_COMPONENT,
            f"unknown component `{component}` in `{text.strip()}`",
            span,
            hint=hint,
        )
        return None
    interface = interfaces[component]
    if interface is None:
        return None
    if index_text is not None and interface.port(f"{port_name}[{index_text}]") is not None:
        # An FMI 2 variable named like an element that was not grouped into an array (`v[1]`
        # and `v[3]` with no `v[2]`, `v[0]`, or beside a scalar `v`): listed, settable, said
        # unconnected by W030, and it could not be named in a connection (a bug hunt).
        port_name, index_text = f"{port_name}[{index_text}]", None
    port = interface.port(port_name)
    unsupported = interface.fact(f"unsupported.{port_name}") if port is None else None
    if unsupported is not None:
        bag.emit(
            codes.UNSUPPORTED_VARIABLE,
            f"`{component}.{port_name}` is not supported yet: it is an {unsupported}",
            span,
            notes=[Note(f"read from `{interface.path.name}`")],
        )
        return None
    if port is None:
        hint = _port_hint(interface, component, port_name, role)
        bag.emit(
            codes.UNKNOWN_PORT,
            f"component `{component}` ({interface.kind}) has no port `{port_name}`",
            span,
            hint=hint,
            notes=[Note(f"ports are read from `{interface.path.name}`")],
        )
        return None
    index: tuple[int, ...] | None = None
    count = port.size
    if index_text is not None:
        index = tuple(int(part) for part in index_text.split(","))
        if not _index_ok(port, index, span, component, bag):
            return None
        count = 1
    return ResolvedEndpoint(PortRef(component, port_name, index), port, count)


def _port_hint(
    interface: ComponentInterface, component: str, name: str, role: Causality | None
) -> str:
    """A close name among the ports that fit ``role`` (else among all), or those ports."""
    fitting = [p.name for p in interface.ports if role is None or p.causality is role]
    close = did_you_mean(name, fitting)
    if close is not None:
        return close
    if role is not None and fitting:
        listed = one_of(fitting).removeprefix("expected one of ")
        return f"expected {_a(role.value)} of `{component}`: {listed}"
    names = [p.name for p in interface.ports]
    return did_you_mean(name, names) or one_of(names)


def _a(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word


def _index_ok(
    port: Port, index: tuple[int, ...], span: Span, component: str, bag: DiagnosticBag
) -> bool:
    where = f"`{component}.{port.name}`"
    if port.is_scalar:
        bag.emit(
            codes.BAD_INDEX, f"{where} is a scalar and cannot be indexed", span, hint="drop `[...]`"
        )
        return False
    size = port.size
    if len(index) == 1:
        if size is not None and index[0] >= size:
            bag.emit(
                codes.BAD_INDEX,
                f"index {index[0]} is out of range for {where} of shape {port.shape_text()}",
                span,
                hint=f"indices are 0-based: 0 to {size - 1}",
            )
            return False
        return True
    if len(index) != len(port.shape):
        bag.emit(
            codes.BAD_INDEX,
            f"{where} has {len(port.shape)} dimensions but the index has {len(index)}",
            span,
            hint="give one flat index or one index per dimension",
        )
        return False
    for axis, (i, dim) in enumerate(zip(index, port.shape, strict=True)):
        if isinstance(dim, int) and i >= dim:
            bag.emit(
                codes.BAD_INDEX,
                f"index {i} on axis {axis} is out of range for {where} of shape {port.shape_text()}",
                span,
            )
            return False
    return True
