"""Diagnostics are data: a stable code table, source spans, and collected findings.

Every user-facing problem (bad YAML, a missing file, a type mismatch, a cycle) becomes a
:class:`Diagnostic` with a code from :data:`CODES`, a severity, a message, a :class:`Span` in
the file the user wrote, optional notes pointing into model files, and a hint. Stages collect
them into a :class:`DiagnosticBag` instead of raising, so one run reports every problem.
Rendering lives in :mod:`fmionnx.report`.
"""

from __future__ import annotations

import difflib
import enum
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from fmionnx.core.pathnames import shown


class Severity(enum.IntEnum):
    """How bad a finding is; ordered so that ``max()`` gives the worst."""

    INFO = 0
    WARNING = 1
    ERROR = 2

    @property
    def label(self) -> str:
        """Lower-case name used in text output (``error``, ``warning``, ``info``)."""
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class Span:
    """A position in a source file: 1-based line and column; 0 means "whole file"."""

    file: Path
    line: int = 0
    col: int = 0

    def __str__(self) -> str:
        name = shown(self.file)
        if self.line <= 0:
            return name
        if self.col <= 0:
            return f"{name}:{self.line}"
        return f"{name}:{self.line}:{self.col}"


@dataclass(frozen=True, slots=True)
class ErrorCode:
    """One entry of the stable code table (in the spirit of ``mypy/errorcodes.py``)."""

    code: str
    name: str
    severity: Severity
    category: str
    description: str


def _codes(*entries: ErrorCode) -> dict[str, ErrorCode]:
    table: dict[str, ErrorCode] = {}
    for entry in entries:
        if entry.code in table:
            msg = f"duplicate diagnostic code {entry.code}"
            raise ValueError(msg)
        table[entry.code] = entry
    return table


_E = Severity.ERROR
_W = Severity.WARNING
_I = Severity.INFO

#: The stable table of every diagnostic code. Codes are never renumbered; retired codes stay.
#: Ranges: E00x syntax/schema, E01x model files, E02x endpoints, E03x connection checks,
#: E04x run settings and parameters, E05x graph, E06x ROS 2, E07x SSP, E08x interface lock,
#: E09x checks.
CODES: dict[str, ErrorCode] = _codes(
    # --- system file syntax and schema
    ErrorCode("E001", "syntax", _E, "syntax", "The system file is not well-formed YAML/XML."),
    ErrorCode("E002", "unknown-key", _E, "schema", "A key that the format does not define."),
    ErrorCode("E003", "invalid-value", _E, "schema", "A value of the wrong type or out of range."),
    ErrorCode("E004", "missing-key", _E, "schema", "A required key is missing."),
    ErrorCode("E005", "format-version", _E, "schema", "Unsupported `fmionnx:` format version."),
    ErrorCode("E006", "encoding", _E, "syntax", "The file is not UTF-8 text."),
    ErrorCode("E007", "duplicate-key", _E, "syntax", "A key appears twice in one mapping."),
    ErrorCode(
        "E008",
        "resource-limit",
        _E,
        "model",
        "A model or file is larger than a resource limit (array elements, file size).",
    ),
    # --- model files
    ErrorCode("E010", "file-not-found", _E, "model", "A referenced file does not exist."),
    ErrorCode(
        "E011", "not-a-file", _E, "model", "A directory or special file where a file is expected."
    ),
    ErrorCode(
        "E012",
        "bad-model",
        _E,
        "model",
        "The model file cannot be read (corrupt archive, bad XML, bad protobuf).",
    ),
    ErrorCode(
        "E013",
        "unsupported-model",
        _E,
        "model",
        "A model version or feature fmionnx does not support.",
    ),
    ErrorCode("E014", "unknown-kind", _E, "schema", "A component kind that is not registered."),
    ErrorCode(
        "E015",
        "no-binary",
        _E,
        "model",
        "The FMU has no binary for this platform (and no sources to build).",
    ),
    ErrorCode(
        "E016",
        "interface-type",
        _E,
        "model",
        "The FMU does not offer the requested interface type (CS/ME).",
    ),
    ErrorCode(
        "E017",
        "unsafe-archive",
        _E,
        "model",
        "An archive or model file that reaches outside its place, or an excessive archive.",
    ),
    ErrorCode(
        "E018",
        "unknown-option",
        _E,
        "schema",
        "An option that does not apply to this component kind.",
    ),
    ErrorCode(
        "E019",
        "invalid-model",
        _E,
        "model",
        "A model fails its format's own validation (FMPy, the ONNX checker and shape inference).",
    ),
    # --- endpoints
    ErrorCode(
        "E020",
        "unknown-component",
        _E,
        "endpoint",
        "A connection names a component that does not exist.",
    ),
    ErrorCode(
        "E021",
        "unknown-port",
        _E,
        "endpoint",
        "A connection names a port the component does not have.",
    ),
    ErrorCode(
        "E022",
        "bad-index",
        _E,
        "endpoint",
        "An element index that is out of range or on a scalar port.",
    ),
    ErrorCode(
        "E023",
        "bad-endpoint",
        _E,
        "endpoint",
        "An endpoint that is not of the form `component.port[index]`.",
    ),
    ErrorCode(
        "E024",
        "missing-function",
        _E,
        "model",
        "An FMU's shared library does not export a function its interface type requires.",
    ),
    ErrorCode(
        "E025",
        "unsupported-variable",
        _E,
        "model",
        "A system uses a model variable fmionnx does not support yet: an FMI 3 clock (named in "
        "an endpoint, or needed by the model).",
    ),
    # --- connection checks
    ErrorCode(
        "E030",
        "causality",
        _E,
        "connection",
        "A connection must go from an output to an input or parameter.",
    ),
    ErrorCode("E031", "dtype", _E, "connection", "Element types on both ends cannot be converted."),
    ErrorCode("E032", "shape", _E, "connection", "Element counts on both ends differ."),
    ErrorCode(
        "E033",
        "unit",
        _E,
        "connection",
        "The ends' units measure different quantities, or differ and cannot be compared.",
    ),
    ErrorCode(
        "E034",
        "multiple-drivers",
        _E,
        "connection",
        "An input is driven by more than one connection.",
    ),
    ErrorCode("E035", "algebraic-loop", _E, "graph", "A cycle through direct-feedthrough ports."),
    ErrorCode("E036", "self-connection", _E, "connection", "A connection from a port to itself."),
    ErrorCode(
        "W030",
        "unconnected-input",
        _W,
        "connection",
        "An input nobody drives: its start value is used.",
    ),
    ErrorCode(
        "W031",
        "lossy-conversion",
        _W,
        "connection",
        "A conversion that may lose precision or range.",
    ),
    ErrorCode(
        "I033",
        "unit-conversion",
        _I,
        "connection",
        "Units of the same quantity that differ: the connection converts (or, suppressed, says "
        "it does not).",
    ),
    ErrorCode(
        "W033",
        "unit-suspicious",
        _W,
        "connection",
        "Values pass between different quantities (conversion suppressed), or a factor that "
        "repeats the automatic unit conversion.",
    ),
    # --- run settings and parameters
    ErrorCode("E040", "run-settings", _E, "run", "Start, stop or step time are inconsistent."),
    ErrorCode(
        "E041", "period", _E, "run", "A component period is not a whole multiple of the base step."
    ),
    ErrorCode(
        "E042",
        "unknown-parameter",
        _E,
        "parameter",
        "A parameter or start value the model does not have.",
    ),
    ErrorCode(
        "E043", "parameter-value", _E, "parameter", "A parameter value of the wrong type or shape."
    ),
    ErrorCode(
        "E044",
        "parameter-causality",
        _E,
        "parameter",
        "A value set on a variable that may not be set.",
    ),
    ErrorCode(
        "E045",
        "plot",
        _E,
        "run",
        "A plot names a signal, reference or file that does not exist or is not allowed.",
    ),
    ErrorCode(
        "E046",
        "plot-signal",
        _E,
        "run",
        "A plotted signal that cannot be drawn: an image, a string, a parameter, an array "
        "on an xy axis.",
    ),
    ErrorCode(
        "E047",
        "output-interval",
        _E,
        "run",
        "The output interval is not a whole multiple of the base step.",
    ),
    ErrorCode(
        "W040", "long-run", _W, "run", "A run of more than 10^8 base steps (it may take hours)."
    ),
    # --- graph
    ErrorCode("E050", "duplicate-component", _E, "graph", "Two components share a name."),
    ErrorCode("W050", "isolated-component", _W, "graph", "A component with no connections at all."),
    ErrorCode(
        "E051",
        "loop-rollback",
        _E,
        "graph",
        "A component of an algebraic loop to iterate cannot repeat a step from a saved state.",
    ),
    ErrorCode(
        "E052",
        "loop-period",
        _E,
        "graph",
        "The components of an algebraic loop to iterate do not share one period.",
    ),
    ErrorCode(
        "E053",
        "loop-values",
        _E,
        "graph",
        "An algebraic loop to iterate exchanges values that are not floating-point numbers.",
    ),
    # --- ROS 2 (issue: ROS 2 mode)
    ErrorCode("E060", "ros2-type", _E, "ros2", "Unknown ROS 2 message type."),
    ErrorCode(
        "E061",
        "ros2-field",
        _E,
        "ros2",
        "A message field that does not exist or does not fit the port.",
    ),
    ErrorCode("E062", "ros2-name", _E, "ros2", "A node or topic name that ROS 2 does not allow."),
    ErrorCode("E063", "ros2-qos", _E, "ros2", "Unknown or inconsistent QoS profile."),
    ErrorCode(
        "E064", "ros2-unmapped", _E, "ros2", "A port that cannot be mapped onto a ROS 2 topic."
    ),
    ErrorCode(
        "E065",
        "ros2-reference",
        _E,
        "ros2",
        "The ros2 section names a component or port that does not exist.",
    ),
    # --- SSP (issue: SSP)
    ErrorCode("E070", "ssp-schema", _E, "ssp", "The SSD does not validate against the SSP XSD."),
    ErrorCode("E071", "ssp-unsupported", _E, "ssp", "An SSP feature fmionnx does not support yet."),
    ErrorCode(
        "E072",
        "ssp-reference",
        _E,
        "ssp",
        "An SSP element references something that does not exist.",
    ),
    ErrorCode(
        "E073",
        "ssp-junction",
        _E,
        "ssp",
        "System connectors that cannot be flattened (driven twice, or in a cycle).",
    ),
    ErrorCode("W070", "ssp-ignored", _W, "ssp", "An SSP element that fmionnx reads but ignores."),
    ErrorCode("I070", "ssp-layout", _I, "ssp", "The SSP diagram layout (geometry) is not used."),
    # --- interface lock (issue: CI)
    ErrorCode(
        "E080",
        "lock-interface-changed",
        _E,
        "lock",
        "A model's interface differs from the lock file.",
    ),
    ErrorCode("E081", "lock-missing", _E, "lock", "No lock file, or a component missing from it."),
    ErrorCode("E082", "lock-invalid", _E, "lock", "The lock file cannot be read."),
    ErrorCode(
        "I080", "lock-binary-changed", _I, "lock", "The model file changed, its interface did not."
    ),
    # --- checks (issue #16)
    ErrorCode("E090", "check-syntax", _E, "checks", "A check expression that does not parse."),
    ErrorCode(
        "E091", "check-signal", _E, "checks", "A check names a signal that cannot be measured."
    ),
    ErrorCode(
        "E092",
        "check-reference",
        _E,
        "checks",
        "A check names a site, component or expected path that does not exist.",
    ),
    ErrorCode(
        "E093", "check-meaning", _E, "checks", "A check expression that parses but means nothing."
    ),
    ErrorCode("E094", "duplicate-check", _E, "checks", "Two checks share a name."),
    # --- studies (issue #15): `fmionnx sweep`
    ErrorCode("E100", "study-file", _E, "study", "A study file that is missing or not a study."),
    ErrorCode(
        "E101",
        "study-system",
        _E,
        "study",
        "The study's system file is missing or does not compile.",
    ),
    ErrorCode(
        "E102",
        "study-target",
        _E,
        "study",
        "A study target that names no parameter, system input, run setting or component.",
    ),
    ErrorCode(
        "E103", "study-values", _E, "study", "Values that do not fit their target, or no sampling."
    ),
    ErrorCode(
        "E104", "study-metric", _E, "study", "A metric named like one of the system's checks."
    ),
    ErrorCode("E105", "study-objective", _E, "study", "An objective that names no metric."),
    ErrorCode("E106", "study-size", _E, "study", "A study of more than a million cases."),
    ErrorCode(
        "E107",
        "study-setting",
        _E,
        "study",
        "A study target that names no parameter or setting of its component.",
    ),
    ErrorCode(
        "E108",
        "study-setting-value",
        _E,
        "study",
        "A value that a component's setting refuses (a signal's or a scene's).",
    ),
    ErrorCode(
        "E109",
        "study-column",
        _E,
        "study",
        "A target or metric name the study's table cannot take as a column (one of its own "
        "columns, another's name, not a short plain name).",
    ),
    ErrorCode(
        "W100",
        "study-plots",
        _W,
        "study",
        "More metrics than the study's summary plots draw (the table has them all).",
    ),
)


@dataclass(frozen=True, slots=True)
class Note:
    """A secondary location, e.g. ``modelDescription.xml:42`` where a variable is declared."""

    message: str
    span: Span | None = None


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One finding. ``code`` is a key of :data:`CODES`; severity defaults to the code's."""

    code: str
    message: str
    span: Span | None = None
    hint: str | None = None
    notes: tuple[Note, ...] = ()
    severity: Severity = field(default=Severity.ERROR)

    @property
    def name(self) -> str:
        """The code's symbolic name (``dtype``, ``unknown-port`` ...)."""
        return CODES[self.code].name

    def sort_key(self) -> tuple[str, int, int, str, str]:
        """Order by file, line, column, then code, so output is stable."""
        span = self.span
        if span is None:
            return ("", 0, 0, self.code, self.message)
        return (str(span.file), span.line, span.col, self.code, self.message)


def make(
    code: str,
    message: str,
    span: Span | None = None,
    *,
    hint: str | None = None,
    notes: Iterable[Note] = (),
) -> Diagnostic:
    """Build a diagnostic with the severity from the code table."""
    entry = CODES[code]
    return Diagnostic(
        code=code,
        message=message,
        span=span,
        hint=hint,
        notes=tuple(notes),
        severity=entry.severity,
    )


class DiagnosticBag:
    """Collects diagnostics across stages; never raises for user mistakes."""

    def __init__(self) -> None:
        self._items: list[Diagnostic] = []

    def add(self, diagnostic: Diagnostic) -> None:
        """Record one diagnostic."""
        self._items.append(diagnostic)

    def emit(
        self,
        code: str,
        message: str,
        span: Span | None = None,
        *,
        hint: str | None = None,
        notes: Iterable[Note] = (),
    ) -> Diagnostic:
        """Build (with :func:`make`) and record a diagnostic; returns it."""
        diagnostic = make(code, message, span, hint=hint, notes=notes)
        self._items.append(diagnostic)
        return diagnostic

    def extend(self, diagnostics: Iterable[Diagnostic]) -> None:
        """Record several diagnostics."""
        self._items.extend(diagnostics)

    @property
    def has_errors(self) -> bool:
        """True when at least one error was recorded."""
        return any(d.severity is Severity.ERROR for d in self._items)

    def sorted(self) -> list[Diagnostic]:
        """All diagnostics, deduplicated and in stable order."""
        unique = dict.fromkeys(self._items)
        return sorted(unique, key=Diagnostic.sort_key)

    def __iter__(self) -> Iterator[Diagnostic]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)


def did_you_mean(word: str, candidates: Iterable[str]) -> str | None:
    """A ``did you mean `x`?`` hint for the closest candidate, or None when nothing is close."""
    matches = difflib.get_close_matches(word, list(candidates), n=1, cutoff=0.6)
    if not matches:
        return None
    return f"did you mean `{matches[0]}`?"


def one_of(candidates: Iterable[str], limit: int = 12) -> str:
    """Render the valid choices for a hint: ``expected one of `a`, `b`, `c```."""
    names = sorted(set(candidates))
    shown = ", ".join(f"`{n}`" for n in names[:limit])
    more = f" (and {len(names) - limit} more)" if len(names) > limit else ""
    return f"expected one of {shown}{more}" if names else "there are none"
