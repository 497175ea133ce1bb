"""The shared vocabulary of every layer: element types, ports, interfaces, components.

Model readers (kinds), the compiler, the runtime and the backends all speak in these terms, so
they live at the bottom and import nothing else of fmionnx but spans.
"""

from __future__ import annotations

import enum
import math
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TypeGuard

from fmionnx.core.diagnostics import Span
from fmionnx.core.units import Unit

#: A scalar value as found in start values and parameters.
Scalar = float | int | bool | str


def is_number(value: object) -> TypeGuard[int | float]:
    """An int or a float, not a bool: Python's ``True`` is the int 1, and a setting that
    takes a number never means a truth value."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def is_hex_bytes(text: str) -> bool:
    """Whether ``text`` is hexadecimal text of whole bytes (``0c0d``), as FMI 3 writes binary
    start values and fmionnx takes a Binary port's value."""
    try:
        bytes.fromhex(text)
    except ValueError:
        return False
    return True


#: Largest finite float32, above which a value silently becomes infinity.
_FLOAT32_MAX = 3.4028234663852886e38


def number_text(value: object) -> str:
    """A value for a message, short; ``str()`` of a huge integer would raise or flood."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"an integer of {value.bit_length()} bits (about 2**{value.bit_length() - 1})"
    return repr(value)


def _bound_text(bound: float) -> str:
    """``13`` for a whole bound (kept interfaces read integers back as floats), else repr."""
    whole = isinstance(bound, float) and bound.is_integer() and abs(bound) < 2**53
    return repr(int(bound)) if whole else repr(bound)


class DType(enum.StrEnum):
    """Element types, named like numpy dtypes. FMI and ONNX types map onto these."""

    FLOAT64 = "float64"
    FLOAT32 = "float32"
    INT8 = "int8"
    INT16 = "int16"
    INT32 = "int32"
    INT64 = "int64"
    UINT8 = "uint8"
    UINT16 = "uint16"
    UINT32 = "uint32"
    UINT64 = "uint64"
    BOOL = "bool"
    STRING = "string"
    BINARY = "binary"

    @property
    def is_float(self) -> bool:
        """Floating-point types."""
        return self in (DType.FLOAT64, DType.FLOAT32)

    @property
    def is_integer(self) -> bool:
        """Signed and unsigned integer types (not bool)."""
        return self.value.startswith(("int", "uint"))

    def out_of_range(self, value: object) -> str | None:
        """Why a number cannot be held by this type (a phrase), or None when it can.

        Only numbers are judged (their kind is checked elsewhere): an integer must fit the
        integer type's bits, and a finite number given for a float type must not overflow it
        (it would silently become infinity). NaN is refused: every value computed from it is
        NaN, and where that value is passed on by no connection (whose check would catch it)
        a run completed with NaN results. An explicit infinity is left alone (a limit).
        """
        if not is_number(value):
            return None
        if isinstance(value, float) and math.isnan(value):
            return "is not a number (NaN); a parameter takes a number (an infinity is allowed)"
        if self.is_integer and isinstance(value, int):
            bits = int(self.value.removeprefix("u").removeprefix("int"))
            signed = not self.value.startswith("u")
            low = -(2 ** (bits - 1)) if signed else 0
            high = 2 ** (bits - 1) - 1 if signed else 2**bits - 1
            if not low <= value <= high:
                return f"is outside the range of {self.value} ({low} to {high})"
        if self.is_float and (isinstance(value, int) or math.isfinite(value)):
            largest = _FLOAT32_MAX if self is DType.FLOAT32 else sys.float_info.max
            if abs(value) > largest:
                return f"is beyond the range of {self.value} (about ±{largest:.2g})"
        return None

    @property
    def is_numeric(self) -> bool:
        """Types that can be converted to one another numerically (bool counts as 0/1)."""
        return self.is_float or self.is_integer or self is DType.BOOL


class Causality(enum.StrEnum):
    """FMI causality vocabulary, used for every kind (ONNX inputs are ``input`` etc.)."""

    INPUT = "input"
    OUTPUT = "output"
    PARAMETER = "parameter"
    CALCULATED_PARAMETER = "calculatedParameter"
    STRUCTURAL_PARAMETER = "structuralParameter"
    LOCAL = "local"
    INDEPENDENT = "independent"


@dataclass(frozen=True, slots=True)
class Port:
    """A named, typed value a component reads or writes.

    ``shape`` is ``()`` for a scalar; a ``str`` entry is a symbolic ONNX dimension. ``start`` is
    flattened in row-major order. ``depends_on`` lists, for an output, the inputs it depends on
    *directly* (within the same step); ``None`` means unknown, which the compiler treats as
    "all inputs". ``vrs`` holds FMU value references, one per element (FMI 2 exporters write
    arrays as scalars ``x[1]``..``x[n]``; the FMU reader groups them into one port).

    ``unit`` is the unit's name as the model writes it (what tables and plot labels show);
    ``unit_definition`` is what the name means (SI exponents, factor, offset) when the model
    defines it or the name is a built-in unit, else None: then only the name can be compared.
    ``relative_quantity`` (FMI ``relativeQuantity``) marks a difference, such as a temperature
    difference, whose unit conversion ignores offsets.
    """

    name: str
    causality: Causality
    dtype: DType
    shape: tuple[int | str, ...] = ()
    unit: str | None = None
    start: tuple[Scalar, ...] | None = None
    variability: str | None = None
    description: str = ""
    depends_on: tuple[str, ...] | None = None
    vrs: tuple[int, ...] = ()
    origin: Span | None = None
    unit_definition: Unit | None = None
    relative_quantity: bool = False
    #: The declared smallest and largest value (FMI ``min``/``max``, the variable's or its
    #: declared type's); None where not declared.
    bounds: tuple[float | None, float | None] = (None, None)

    def bounds_problem(self, value: object) -> str | None:
        """Why ``value`` lies outside the declared ``min``/``max`` (a phrase), or None.

        FMI makes a value outside them an error of whoever sets it; models that check
        (most do not) fail at initialization with a message of their own, the others run
        with a value their author ruled out (a bug hunt: ``mode=99`` of a ``max="13"``).
        """
        if not is_number(value) or math.isnan(value):
            return None
        low, high = self.bounds
        if low is not None and value < low:
            return f"is below the declared min {_bound_text(low)} of `{self.name}`"
        if high is not None and value > high:
            return f"is above the declared max {_bound_text(high)} of `{self.name}`"
        return None

    @property
    def is_scalar(self) -> bool:
        """True for a port of shape ``()``."""
        return not self.shape

    @property
    def size(self) -> int | None:
        """Number of elements, or None when a dimension is symbolic."""
        total = 1
        for dim in self.shape:
            if isinstance(dim, str):
                return None
            total *= dim
        return total

    def shape_text(self) -> str:
        """``scalar`` or ``[1,480,640,3]`` for messages and tables."""
        if not self.shape:
            return "scalar"
        return "[" + ",".join(str(d) for d in self.shape) + "]"


@dataclass(frozen=True, slots=True)
class Experiment:
    """A model's default experiment (FMI ``DefaultExperiment``)."""

    start: float | None = None
    stop: float | None = None
    step: float | None = None
    tolerance: float | None = None


@dataclass(frozen=True, slots=True)
class ComponentInterface:
    """What a model file offers, read from the file itself (never from the system file).

    ``facts`` are human- and lock-relevant key/value strings such as ``fmiVersion``,
    ``instantiationToken``, ``modelIdentifier``, ``interfaceTypes``, ``opset``; each kind
    documents the keys it writes. ``content_hash`` is the sha256 of the model file(s).
    """

    kind: str
    path: Path
    ports: tuple[Port, ...]
    facts: tuple[tuple[str, str], ...] = ()
    default_experiment: Experiment | None = None
    content_hash: str = ""

    def port(self, name: str) -> Port | None:
        """The port called ``name``, or None."""
        for port in self.ports:
            if port.name == name:
                return port
        return None

    def fact(self, key: str) -> str | None:
        """The value of a fact, or None."""
        for k, v in self.facts:
            if k == key:
                return v
        return None

    def with_causality(self, *causalities: Causality) -> Iterator[Port]:
        """Ports whose causality is one of ``causalities``, in declaration order."""
        return (p for p in self.ports if p.causality in causalities)


@dataclass(frozen=True, slots=True)
class PortRef:
    """A resolved endpoint: component name, port name, optional element index (0-based)."""

    component: str
    port: str
    index: tuple[int, ...] | None = None

    @property
    def port_label(self) -> str:
        """The port with its index, without the component: ``base_quat[0]``."""
        if self.index is None:
            return self.port
        return self.port + "[" + ",".join(str(i) for i in self.index) + "]"

    def __str__(self) -> str:
        return f"{self.component}.{self.port_label}"


class ValueSource(enum.StrEnum):
    """Where a parameter or start value came from; ``run.json`` records it with the value."""

    SYSTEM_FILE = "system file"
    SSV_FILE = "ssv file"
    SSP_INLINE = "ssp inline"
    SSP_ANNOTATION = "ssp annotation"
    COMMAND_LINE = "command line"
    STUDY = "study"


@dataclass(frozen=True, slots=True)
class ParameterValue:
    """A value set on a variable before initialization (parameter or start value).

    ``source`` says where the value was written (resolved by the compiler, replaced by an
    override), so that every backend and ``run.json`` can tell without reading the file again.
    """

    port: str
    value: tuple[Scalar, ...]
    span: Span | None = None
    source: ValueSource = ValueSource.SYSTEM_FILE


@dataclass(frozen=True, slots=True)
class KindConfig:
    """Base of every kind's resolved configuration (a frozen dataclass per kind).

    ``kind`` names the kind so that a serialised compiled system can be read back: the kind
    table maps it to the config class.
    """

    kind: str


@dataclass(frozen=True, slots=True)
class Component:
    """A component instance in the system: its model, interface, rate and resolved settings.

    ``config`` is the kind's own frozen, resolved configuration (FMU interface type, cameras,
    providers ...), made by the kind at compile time: nothing here refers to the system file's
    raw model. ``period_steps`` is the period in base steps. ``external`` components are
    provided from outside in ROS 2 mode (no node is started for them). ``declared_path`` is the
    model path as the system file wrote it (the interface lock records it). A component whose
    entry names no model file (its kind lets ``path`` be omitted) has an empty
    ``declared_path``, and ``path`` is the system file, where it is defined.
    """

    name: str
    kind: str
    path: Path
    interface: ComponentInterface
    config: KindConfig
    period: float
    period_steps: int
    parameters: tuple[ParameterValue, ...] = ()
    span: Span | None = None
    external: bool = False
    declared_path: str = ""

    def port(self, name: str) -> Port:
        """The port called ``name``; raises KeyError (a compiler bug) when absent."""
        port = self.interface.port(name)
        if port is None:
            msg = f"{self.name} has no port {name}"
            raise KeyError(msg)
        return port


def is_whole_multiple(period: float, step: float, *, rel: float = 1e-9) -> int | None:
    """``period / step`` when it is a positive whole number (within ``rel``), else None."""
    ratio = period / step
    if not math.isfinite(ratio):  # round() would raise OverflowError (or ValueError for NaN)
        return None
    nearest = round(ratio)
    if nearest >= 1 and math.isclose(ratio, nearest, rel_tol=rel, abs_tol=rel):
        return nearest
    return None


def flat_index(port: Port, index: tuple[int, ...]) -> int:
    """Row-major flat element index of ``index`` in ``port`` (a single index is already flat)."""
    if len(index) == 1:
        return index[0]
    flat = 0
    for i, dim in zip(index, port.shape, strict=True):
        flat = flat * (dim if isinstance(dim, int) else 1) + i
    return flat
