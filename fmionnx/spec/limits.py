"""Resource limits of the YAML front end, checked on the event stream before any node is built.

A system file or a lock file comes from anywhere (a colleague, a pull request, a download), so
reading one must stay cheap whatever it holds. Three inputs would otherwise exhaust the machine
before a single diagnostic is printed:

* a "billion laughs" document, whose nested anchors and aliases expand to billions of nodes
  when the loaded data is walked (converted, validated);
* deeply nested collections (``[[[[...``), which make the recursive composer and every later
  recursive walk raise ``RecursionError``;
* a huge document.

The check runs over the parser's *events* (the libyaml C parser when available): the parser is
iterative and nothing is expanded, so the check costs one linear pass and stops at the first
excess. It also refuses numeric literals beyond the range of a double (``1e400``, a 5000-digit
integer): YAML would read them as ``inf`` or as integers that no model variable can hold, and
Python refuses to parse integers of more than 4300 digits with a bare ``ValueError``.

The limits are module constants, deliberately not configurable: they are far above what a
real system or lock file needs (``fmionnx lock`` writes no alias and nests a few levels, one
port per line), and a fixed limit keeps a file valid or invalid on every machine.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span

if TYPE_CHECKING:  # ruamel is imported when a document is checked: a lone model reads none
    from ruamel.yaml.events import ScalarEvent

#: Largest document read, in bytes (system files and lock files alike).
MAX_DOCUMENT_BYTES = 16 * 1024 * 1024
#: Deepest nesting of maps and lists (the top-level map is depth 1).
MAX_DEPTH = 100
#: Most nodes that all aliases of a document may expand to, together. An alias counts as the
#: whole subtree it repeats, so a handful of nested anchors cannot stand for billions of nodes.
MAX_ALIAS_NODES = 10_000

#: Plain scalars that YAML 1.2 (ruamel's default) reads as numbers; ``.inf``/``.nan`` are
#: spelled out and therefore never "overflow" silently.
_NUMBER = re.compile(
    r"[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)(?:[eE][-+]?[0-9]+)?"
    r"|[-+]?0x[0-9a-fA-F_]+|[-+]?0o[0-7_]+"
)


class _LimitError(Exception):
    """Stops the event loop at the first excess (the diagnostic is already in the bag)."""


@dataclass
class _Frame:
    """An open map or list: its anchor and how many nodes it holds so far (itself included)."""

    anchor: str | None
    nodes: int = 1


@dataclass
class _Counter:
    """Depth, alias expansion and number ranges of one document, fed event by event."""

    path: Path
    bag: DiagnosticBag
    stack: list[_Frame] = field(default_factory=list)
    anchored: dict[str, int] = field(default_factory=dict)
    alias_nodes: int = 0

    def span(self, event: Any) -> Span:
        mark = event.start_mark
        return Span(self.path, mark.line + 1, mark.column + 1)

    def fail(self, event: Any, message: str, hint: str) -> None:
        self.bag.emit(codes.INVALID_VALUE, message, self.span(event), hint=hint)
        raise _LimitError

    def add(self, nodes: int) -> None:
        if self.stack:
            self.stack[-1].nodes += nodes

    def feed(self, event: Any) -> None:
        from ruamel.yaml.events import (
            AliasEvent,
            CollectionEndEvent,
            CollectionStartEvent,
            ScalarEvent,
        )

        if isinstance(event, CollectionStartEvent):
            if len(self.stack) >= MAX_DEPTH:
                self.fail(
                    event,
                    f"the document nests maps and lists more than {MAX_DEPTH} levels deep",
                    "flatten the structure; no fmionnx file needs this depth",
                )
            self.stack.append(_Frame(event.anchor))
        elif isinstance(event, CollectionEndEvent):
            frame = self.stack.pop()
            if frame.anchor is not None:
                self.anchored[frame.anchor] = frame.nodes
            self.add(frame.nodes)
        elif isinstance(event, AliasEvent):
            size = self.anchored.get(event.anchor, 1)
            self.alias_nodes += size
            if self.alias_nodes > MAX_ALIAS_NODES:
                self.fail(
                    event,
                    f"aliases expand to more than {MAX_ALIAS_NODES} nodes "
                    f"(`*{event.anchor}` repeats {size})",
                    "write the repeated values out, or use fewer nested anchors",
                )
            self.add(size)
        elif isinstance(event, ScalarEvent):
            self._check_number(event)
            if event.anchor is not None:
                self.anchored[event.anchor] = 1
            self.add(1)

    def _check_number(self, event: ScalarEvent) -> None:
        plain = not event.style and event.tag is None
        if not plain or not _NUMBER.fullmatch(event.value):
            return
        text = event.value.replace("_", "")
        try:
            value = float(int(text, 0)) if text.lower().lstrip("+-")[:2] in {"0x", "0o"} else None
        except (ValueError, OverflowError):
            value = math.inf
        if value is None:
            value = float(text)
        if math.isinf(value):
            self.fail(
                event,
                f"the number `{_short(event.value)}` is beyond the range of a 64-bit float "
                "(about ±1.8e308)",
                "write a smaller number, or `.inf` if infinity is really meant",
            )


def _short(text: str) -> str:
    return text if len(text) <= 24 else f"{text[:12]}...{text[-6:]} ({len(text)} characters)"


def _events(text: str) -> Iterator[Any]:
    """Parser events, from libyaml when it is installed (the pure parser is far slower)."""
    try:
        from ruamel.yaml.cyaml import CParser  # type: ignore[attr-defined]  # from _ruamel_yaml
    except ImportError:  # pragma: no cover - the C extension ships with ruamel.yaml wheels
        from ruamel.yaml import YAML

        yield from YAML(typ="safe", pure=True).parse(text)
        return
    parser = CParser(text)
    while True:
        event = parser.get_event()
        yield event
        if type(event).__name__ == "StreamEndEvent":
            return


def check_size(size: int, path: Path, bag: DiagnosticBag) -> bool:
    """False (and E003 at the file's start) when a document is larger than allowed."""
    if size <= MAX_DOCUMENT_BYTES:
        return True
    bag.emit(
        codes.INVALID_VALUE,
        f"`{path.name}` is {size} bytes, more than the {MAX_DOCUMENT_BYTES} bytes "
        f"({MAX_DOCUMENT_BYTES // (1024 * 1024)} MiB) a YAML file may have",
        Span(path, 1, 1),
        hint="split the system, or keep large data in model files",
    )
    return False


def check_limits(text: str, path: Path, bag: DiagnosticBag) -> bool:
    """True when ``text`` is within every limit; else False with one E003 in ``bag``.

    Syntax errors are left to the loader that follows (it reports them with its own
    positions), so this returns True for a document it cannot parse to the end.
    """
    if not check_size(len(text.encode("utf-8", "surrogatepass")), path, bag):
        return False
    from ruamel.yaml.error import YAMLError

    counter = _Counter(path, bag)
    try:
        for event in _events(text):
            counter.feed(event)
    except _LimitError:
        return False
    except YAMLError:
        return True
    return True
