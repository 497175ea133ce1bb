"""Parse and resolve connection endpoints ``component.port[index]`` against real interfaces.

A port whose name is no dotted word is quoted, ``t."input.1"[0]`` (:data:`ENDPOINT_RE`).
"""

from __future__ import annotations

import itertools
import re
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
    index = match.group("index")
    if match.group("quoted") is not None:  # the quotes hold the whole port name
        return match.group("owner"), match.group("quoted"), index
    name = match.group("name")
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
            hint=_bad_endpoint_hint(text.strip(), interfaces),
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


#: A port name that is written as it is: dotted parts, each starting with a letter, ``_`` or ``$``.
_PLAIN_PORT = re.compile(r"[A-Za-z_$][\w:$-]*(?:\.[A-Za-z_$][\w:$-]*)*")
#: An element index at the end of an endpoint's text.
_TRAILING_INDEX = re.compile(r"\[\s*\d+\s*(?:,\s*\d+\s*)*\]$")


def endpoint_text(ref: PortRef) -> str:
    """``ref`` as an endpoint is written, its port quoted when the name is no dotted word.

    ``str(ref)`` names the port as the model does (``t.input.1``: a results column), which
    the endpoint parser reads differently or not at all; this text parses back to ``ref``.
    """
    port = ref.port if _PLAIN_PORT.fullmatch(ref.port) else f'"{ref.port}"'
    index = "" if ref.index is None else "[" + ",".join(map(str, ref.index)) + "]"
    return f"{ref.component}.{port}{index}"


def without_spaces(text: str) -> str:
    """``text`` without white space, except inside a quoted port name (``w."front left"``).

    Plots take ``a.x [0]`` as ``a.x[0]``; the space of a camera named ``front left`` is part
    of the name.
    """
    pieces = text.split('"')
    return '"'.join(
        piece if inside else re.sub(r"\s+", "", piece)
        for inside, piece in zip(itertools.cycle((False, True)), pieces, strict=False)
    )


def _bad_endpoint_hint(text: str, interfaces: Mapping[str, ComponentInterface | None]) -> str:
    """How to write ``text``, which is no endpoint: quoted, when it names a port that way.

    A model's port named ``input.1`` or ``a b`` can be named only in quotes; the text is
    shown quoted so that the fix can be copied. Text that names no port of the component
    (``g.x[-1]``) gets the grammar instead: quoting it would only lead to E021.
    """
    if '"' in text:
        return (
            'a quoted port name is written `component."port name"`, an index after the closing '
            'quote; the name can be neither empty nor hold `"`'
        )
    plain = "write `component.port`, or `component.port[i]` for one element"
    owners = [c for c in interfaces if text.startswith(c + ".")]
    if owners:
        component = max(owners, key=len)
        quoted = _quoted(text[len(component) + 1 :], interfaces[component])
        if quoted is not None:
            return f"quote a port name that is not a dotted word: `{component}.{quoted}`"
    if "." not in text:
        return plain
    return plain + ', or `component."port name"` for a port whose name is no dotted word'


def _quoted(rest: str, interface: ComponentInterface | None) -> str | None:
    """``"rest"`` (an index kept after the quotes) when it names a port; None when not.

    An unreadable model (None, reported already) cannot say: the quoted text is offered.
    """
    index = _TRAILING_INDEX.search(rest)
    candidates = [(rest, "")]
    if index is not None and index.start() > 0:
        candidates.insert(0, (rest[: index.start()], index.group()))
    for port, suffix in candidates:
        if interface is None or interface.port(port) is not None:
            return f'"{port}"{suffix}'
    return None


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
