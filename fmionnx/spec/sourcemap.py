"""Positions of every key and value of a system file, by key path.

A key path is a tuple such as ``("components", "odometry", "period")`` or
``("connections", 3)``. Front ends record the span of the key and of the value; the compiler
and the pydantic error mapper look them up, falling back to the nearest recorded ancestor.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from fmionnx.core.diagnostics import Span
from fmionnx.core.types import ValueSource
from fmionnx.core.units import Unit

KeyPath = tuple[str | int, ...]


@dataclass
class SourceMap:
    """Maps key paths to the span of the key (``key_spans``) and of the value (``spans``)."""

    file: Path
    spans: dict[KeyPath, Span] = field(default_factory=dict)
    key_spans: dict[KeyPath, Span] = field(default_factory=dict)
    #: Where a value was written when not in the system file itself (an SSP's ``.ssv`` file,
    #: inline parameter set or annotation), by the value's key path.
    sources: dict[KeyPath, ValueSource] = field(default_factory=dict)
    #: The unit a value is written in when it is not the unit of what it sets (an SSV
    #: ``unit``): the compiler converts the value to the port's unit.
    units: dict[KeyPath, Unit] = field(default_factory=dict)

    def value_source(self, path: Sequence[str | int]) -> ValueSource:
        """Where the value at ``path`` was written (the system file unless recorded)."""
        return self.sources.get(tuple(path), ValueSource.SYSTEM_FILE)

    def record(self, path: KeyPath, value: Span, key: Span | None = None) -> None:
        """Remember where ``path``'s value (and key) are."""
        self.spans[path] = value
        if key is not None:
            self.key_spans[path] = key

    def value(self, path: Sequence[str | int]) -> Span:
        """Span of the value at ``path`` or of its nearest known ancestor (file start at worst).

        Path elements that are not in the map (e.g. pydantic's union tags) are skipped.
        """
        return self._find(tuple(path), self.spans)

    def key(self, path: Sequence[str | int]) -> Span:
        """Span of the key at ``path`` (falls back like :meth:`value`)."""
        return self._find(tuple(path), self.key_spans, fallback=self.spans)

    def _find(
        self,
        path: KeyPath,
        table: dict[KeyPath, Span],
        fallback: dict[KeyPath, Span] | None = None,
    ) -> Span:
        best = Span(self.file, 1, 1)
        prefix: KeyPath = ()
        for element in path:
            candidate = (*prefix, element)
            if candidate in table or candidate in self.spans:
                prefix = candidate
        if prefix in table:
            return table[prefix]
        if fallback is not None and prefix in fallback:
            return fallback[prefix]
        return self.spans.get(prefix, best)
