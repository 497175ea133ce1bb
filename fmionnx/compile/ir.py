"""The compiled system: one immutable intermediate representation between parsing and running.

Front ends (YAML, SSP) produce a raw :class:`~fmionnx.spec.model.SystemSpec`; the compiler
reads every model's real interface and produces a :class:`CompiledSystem`. Backends, ``graph``
and the exporters consume only this; none of them re-reads the system file. Runtime state (FMU
instances, ORT sessions, buffers) lives in backend objects, never here.
"""

from __future__ import annotations

import enum
import hashlib
import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.core.diagnostics import Span

if TYPE_CHECKING:
    from fmionnx.spec.model import ComponentSpec, PlotSpec, Ros2Spec

#: A scalar value as found in start values and parameters.
Scalar = float | int | bool | str


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


@dataclass(frozen=True, slots=True)
class ParameterValue:
    """A value set on a variable before initialization (parameter or start value)."""

    port: str
    value: tuple[Scalar, ...]
    span: Span | None = None


@dataclass(frozen=True, slots=True)
class Component:
    """A component instance in the system: its model, interface, rate and settings.

    ``spec`` is the frozen raw spec of this component (kind-specific options such as cameras
    or the FMU interface type live there). ``period_steps`` is the period in base steps.
    """

    name: str
    kind: str
    path: Path
    interface: ComponentInterface
    spec: ComponentSpec
    period: float
    period_steps: int
    parameters: tuple[ParameterValue, ...] = ()
    span: Span | None = None

    def port(self, name: str) -> Port:
        """The port called ``name``; raises KeyError (a compiler bug) when absent."""
        port = self.interface.port(name)
        if port is None:
            msg = f"{self.name} has no port {name}"
            raise KeyError(msg)
        return port


@dataclass(frozen=True, slots=True)
class Connection:
    """A checked edge from an output element range to an input element range.

    ``size`` elements flow; when an index is given on an end, exactly one element is taken
    or written there. ``factor``/``offset`` apply ``y = factor * x + offset`` (SSP
    ``LinearTransformation``; identity by default).
    """

    src: PortRef
    dst: PortRef
    src_port: Port
    dst_port: Port
    size: int
    factor: float = 1.0
    offset: float = 0.0
    span: Span | None = None

    def __str__(self) -> str:
        return f"{self.src} -> {self.dst}"


class Origin(enum.StrEnum):
    """Where a resolved setting came from (recorded so ``run.json`` can tell)."""

    SYSTEM_FILE = "system file"
    MODEL_DEFAULT = "model default experiment"
    BUILTIN_DEFAULT = "built-in default"
    COMMAND_LINE = "command line"


@dataclass(frozen=True, slots=True)
class RunSettings:
    """Resolved run settings; communication points are ``start + n * step``."""

    start: float
    stop: float
    step: float
    origins: tuple[tuple[str, Origin], ...] = ()

    @property
    def steps(self) -> int:
        """Number of base steps from start to stop."""
        return round((self.stop - self.start) / self.step)

    def time_at(self, n: int) -> float:
        """Time of communication point ``n``, computed, never accumulated."""
        return self.start + n * self.step


@dataclass(frozen=True, slots=True)
class CompiledSystem:
    """The whole checked system. Immutable; make a new one with ``dataclasses.replace``."""

    name: str
    source: Path
    run: RunSettings
    components: tuple[Component, ...]
    connections: tuple[Connection, ...]
    order: tuple[str, ...]
    plots: tuple[PlotSpec, ...] = ()
    record: tuple[PortRef, ...] = ()
    ros2: Ros2Spec | None = None
    description: str = ""
    _index: dict[str, Component] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        self._index.update({c.name: c for c in self.components})

    def component(self, name: str) -> Component:
        """The component called ``name`` (KeyError when absent)."""
        return self._index[name]

    def inputs_of(self, name: str) -> tuple[Connection, ...]:
        """Connections that drive inputs of component ``name``."""
        return tuple(c for c in self.connections if c.dst.component == name)

    def outputs_of(self, name: str) -> tuple[Connection, ...]:
        """Connections fed by outputs of component ``name``."""
        return tuple(c for c in self.connections if c.src.component == name)

    @property
    def content_hash(self) -> str:
        """sha256 over a canonical description of the system and its models' hashes."""
        payload = {
            "name": self.name,
            "run": [self.run.start, self.run.stop, self.run.step],
            "components": [
                {
                    "name": c.name,
                    "kind": c.kind,
                    "model": c.interface.content_hash,
                    "period": c.period,
                    "spec": c.spec.model_dump(mode="json"),
                    "parameters": [[p.port, list(p.value)] for p in c.parameters],
                }
                for c in self.components
            ],
            "connections": [[str(c.src), str(c.dst), c.factor, c.offset] for c in self.connections],
            "order": list(self.order),
        }
        text = json.dumps(payload, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()


def is_whole_multiple(period: float, step: float, *, rel: float = 1e-9) -> int | None:
    """``period / step`` when it is a positive whole number (within ``rel``), else None."""
    ratio = period / step
    nearest = round(ratio)
    if nearest >= 1 and math.isclose(ratio, nearest, rel_tol=rel, abs_tol=rel):
        return nearest
    return None
