"""What a name under the cursor refers to: a component, one of its ports, a site of its scene,
its expected path, or a function of the checks language.

Names are split the way the compiler splits endpoints (:func:`fmionnx.compile.endpoints.
split_endpoint`: the longest component name that prefixes the text), so ``sub.gain.y`` is port
``y`` of component ``sub.gain`` when there is one; a quoted port (``p."input.1"``) is named
whole by its quotes, after the component written before them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from fmionnx.compile.checks import FUNCTIONS
from fmionnx.compile.expected_path import EXPECTED_PATH
from fmionnx.compile.plots import MAP_REFERENCE
from fmionnx.core.types import Port
from fmionnx.lsp.outline import ComponentOutline, Outline
from fmionnx.lsp.yamlcontext import cursor_at, name_at, quoted_port

#: Where a name under the cursor is the port of the entry it is written in (its key).
_OWN_PORT_SECTIONS = ("parameters", "units")


@dataclass(frozen=True, slots=True)
class Reference:
    """A resolved name: ``what`` is ``component``, ``port``, ``site``, ``expected_path``,
    ``map`` or ``function`` (``detail``: its signature); the name is on 0-based ``line`` from
    column ``start`` to ``end``."""

    what: str
    name: str
    component: ComponentOutline | None = None
    port: Port | None = None
    detail: str = ""
    line: int = 0
    start: int = 0
    end: int = 0


def components_of(outline: Outline | None) -> dict[str, ComponentOutline]:
    """The components that names in a file refer to (a study's are its system's)."""
    if outline is None:
        return {}
    if outline.system is not None:
        return dict(outline.system.components)
    return dict(outline.components)


def reference_at(text: str, line: int, column: int, outline: Outline | None) -> Reference | None:
    """What the name at 0-based ``line``/``column`` of ``text`` refers to, or None."""
    lines = text.split("\n")
    found = name_at(lines[line], column) if line < len(lines) else None
    if found is None:
        return None
    name, start = found
    end = start + len(name)
    where = cursor_at(text, line, start)
    components = components_of(outline)
    path = where.path

    def whole(what: str, component: ComponentOutline | None, port: Port | None = None) -> Reference:
        detail = FUNCTIONS.get(name, "") if what == "function" else ""
        return Reference(what, name, component, port, detail, line, start, end)

    # the key of a component's entry, and that entry's own ports under `parameters`/`units`
    if path == ("components",) and where.role == "key" and name in components:
        return whole("component", components[name])
    if len(path) == 3 and path[0] == "components" and path[2] in _OWN_PORT_SECTIONS:
        owner = components.get(path[1])
        port = owner.interface.port(name) if owner and owner.interface else None
        return whole("port", owner, port) if port is not None and where.role == "key" else None
    if "." not in name:
        if name in components and path[:1] != ("components",):
            return whole("component", components[name])  # a ROS 2 node key, an `isolate` entry
        if name in FUNCTIONS and _in_expression(path):
            return whole("function", None)
        return None
    return _dotted(name, components, line, start, end)


def _in_expression(path: tuple[str, ...]) -> bool:
    return path[:1] == ("metrics",) or (path[:1] == ("checks",) and path[-1:] == ("expect",))


def _dotted(
    name: str, components: dict[str, ComponentOutline], line: int, start: int, end: int
) -> Reference | None:
    plain = re.sub(r"\[[^\]]*\]$", "", name)
    quoted = quoted_port(plain)
    parts = _split(plain, components) if quoted is None else quoted
    if parts is None or parts[0] not in components:
        return None
    component_name, rest = parts
    component = components[component_name]

    def found(what: str, named: str, port: Port | None = None) -> Reference:
        return Reference(what, named, component, port, line=line, start=start, end=end)

    if quoted is not None:  # the quotes hold a port's name, never a site or a reference
        port = component.interface.port(rest) if component.interface is not None else None
        return found("component", component_name) if port is None else found("port", name, port)
    if rest == EXPECTED_PATH:
        return found("expected_path", name)
    if rest == MAP_REFERENCE:
        return found("map", name)
    if rest.startswith("site."):
        return found("site", rest.removeprefix("site."))
    port = component.interface.port(rest) if component.interface is not None else None
    if port is None:
        return found("component", component_name)
    return found("port", name, port)


def _split(name: str, components: dict[str, ComponentOutline]) -> tuple[str, str] | None:
    best = ""
    for component in components:
        if name.startswith(component + ".") and len(component) > len(best):
            best = component
    if not best:
        return None
    return best, name[len(best) + 1 :]
