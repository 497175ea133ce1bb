"""Render the compiled dataflow graph as Graphviz DOT, Mermaid or JSON.

Components are nodes styled by kind (FMU, ONNX, MuJoCo) with their rate; connections are edges
labelled with the ports they join. Several connections between the same two components are
merged into one edge with one label line per connection, which keeps the picture readable.

Every text put into the graph (component, port and file names, units) is quoted for the
format it lands in: DOT strings and HTML-like labels, Mermaid labels; and its control
characters are shown escaped (:func:`~fmionnx.core.printable.printable`): an ONNX port name
can hold anything, and a file named ``R&D.fmu`` made Graphviz refuse the whole graph.
"""

from __future__ import annotations

import html
import json
import re
from collections import defaultdict
from typing import Any

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.printable import printable
from fmionnx.core.types import Component
from fmionnx.kinds.base import Display
from fmionnx.kinds.registry import COMPONENT_KINDS


def _display(kind: str) -> Display:
    found = COMPONENT_KINDS.get(kind)
    return found.display if found is not None else Display(kind, "shape=box", ("[", "]"), "#eeeeee")


def _rate(component: Component) -> str:
    if component.period <= 0:
        return ""
    hertz = 1.0 / component.period
    return f"{hertz:g} Hz" if hertz >= 1 else f"every {component.period:g} s"


def _grouped(system: CompiledSystem) -> dict[tuple[str, str], list[str]]:
    edges: dict[tuple[str, str], list[str]] = defaultdict(list)
    for connection in system.connections:
        key = (connection.src.component, connection.dst.component)
        text = f"{connection.src.port_label} → {connection.dst.port_label}"
        if connection.units is not None:  # a unit conversion is part of what the edge does
            text += f" ({connection.units.source} → {connection.units.target})"
        edges[key].append(text)
    return edges


def _dot_quote(text: str) -> str:
    """A DOT quoted string: its backslashes and quotes escaped, so ``\\l`` in a name stays
    text and is not a line break."""
    return '"' + printable(text).replace("\\", "\\\\").replace('"', '\\"') + '"'


def _dot_html(text: str) -> str:
    """Text inside a DOT HTML-like label: ``&``, ``<`` and ``>`` as entities (Graphviz
    parses the label as XML and refuses the whole graph at a bare ``&``)."""
    return html.escape(printable(text), quote=False)


def to_dot(system: CompiledSystem) -> str:
    """Graphviz DOT text (render with ``dot -Tsvg``)."""
    lines = [
        f"digraph {_dot_quote(system.name)} {{",
        "  graph [rankdir=LR, fontname=Helvetica, nodesep=0.6, ranksep=1.1, "
        f"label={_dot_quote(system.name)}, labelloc=t, fontsize=18];",
        '  node [fontname=Helvetica, fontsize=12, margin="0.2,0.1"];',
        '  edge [fontname=Helvetica, fontsize=9, color="#475569", fontcolor="#334155"];',
    ]
    for component in system.components:
        details = [_display(component.kind).label, component.path.name]
        details += [_rate(component)] if _rate(component) else []
        label = (
            f"<<b>{_dot_html(component.name)}</b><br/><font point-size='9'>"
            f"{' · '.join(_dot_html(text) for text in details)}</font>>"
        )
        style = _display(component.kind).dot
        lines.append(f"  {_dot_quote(component.name)} [label={label}, {style}];")
    for (src, dst), labels in sorted(_grouped(system).items()):
        # Escape each line, then join with DOT's left-justified line break `\l`.
        label = '"' + "".join(_dot_quote(text)[1:-1] + "\\l" for text in labels) + '"'
        lines.append(f"  {_dot_quote(src)} -> {_dot_quote(dst)} [label={label}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def _mermaid_ids(names: list[str]) -> dict[str, str]:
    """A Mermaid node id per component name: letters and digits kept, anything else ``_``,
    and ``_2``, ``_3``... where that makes two names one (``a.b``, ``a_b``, ``a-b`` were one
    node fed three times: a bug hunt)."""
    ids: dict[str, str] = {}
    taken: set[str] = set()
    for name in names:
        base = "n_" + "".join(ch if ch.isalnum() else "_" for ch in name)
        chosen, number = base, 1
        while chosen in taken:
            number += 1
            chosen = f"{base}_{number}"
        taken.add(chosen)
        ids[name] = chosen
    return ids


#: Characters a Mermaid label cannot hold as they are: the quote ends it, ``#`` starts an
#: entity code, ``<``/``>``/``&`` are HTML, a backtick starts a Markdown string.
_MERMAID_SPECIAL = re.compile('["#&<>`]')


def _mermaid_text(text: str) -> str:
    """Text inside a quoted Mermaid label: special characters as Mermaid's entity codes
    (``#60;``), which the diagram shows as the character."""
    return _MERMAID_SPECIAL.sub(lambda m: f"#{ord(m.group())};", printable(text))


def to_mermaid(system: CompiledSystem) -> str:
    """Mermaid flowchart text (renders on GitHub and in mkdocs-material)."""
    lines = ["flowchart LR"]
    ids = _mermaid_ids([c.name for c in system.components])
    for component in system.components:
        left, right = _display(component.kind).mermaid
        rate = _rate(component)
        label = f"{_mermaid_text(component.name)}<br/><small>"
        label += _mermaid_text(_display(component.kind).label)
        label += f" · {_mermaid_text(rate)}</small>" if rate else "</small>"
        lines.append(f'  {ids[component.name]}{left}"{label}"{right}')
    for (src, dst), labels in sorted(_grouped(system).items()):
        text = "<br/>".join(_mermaid_text(label) for label in labels)
        lines.append(f'  {ids[src]} -- "{text}" --> {ids[dst]}')
    for kind, colour in ((k, d.display.colour) for k, d in COMPONENT_KINDS.items()):
        members = [ids[c.name] for c in system.components if c.kind == kind]
        if members:
            lines.append(f"  classDef {kind} fill:{colour}")
            lines.append(f"  class {','.join(members)} {kind}")
    return "\n".join(lines) + "\n"


def to_json(system: CompiledSystem) -> dict[str, Any]:
    """A stable JSON description: nodes, edges (one per connection) and the execution order;
    ``loops`` (only when the system iterates algebraic loops): members, tear inputs, cycle."""
    document = {
        "version": 1,
        "name": system.name,
        "nodes": [
            {
                "name": c.name,
                "kind": c.kind,
                "model": c.path.name,
                "period": c.period,
                "external": c.external,
            }
            for c in system.components
        ],
        "edges": [
            {
                "from": str(c.src),
                "to": str(c.dst),
                "source": c.src.component,
                "target": c.dst.component,
                "dtype": str(c.src_port.dtype),
                "size": c.size,
            }
            for c in system.connections
        ],
        "order": list(system.order),
    }
    if system.loops:
        document["loops"] = [
            {
                "members": list(loop.members),
                "tears": [str(ref) for ref in loop.tears],
                "cycle": list(loop.cycle),
                "solver": loop.solver.method,
            }
            for loop in system.loops
        ]
    return document


def to_json_text(system: CompiledSystem) -> str:
    """:func:`to_json` as indented text."""
    return json.dumps(to_json(system), indent=2) + "\n"
