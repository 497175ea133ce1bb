"""The compiled system: one immutable intermediate representation between parsing and running.

Front ends (YAML, SSP) produce a raw system spec; the compiler reads every model's real
interface and produces a :class:`CompiledSystem`. Backends, ``graph``, the exporters, ROS 2
nodes and sweep workers consume only this; none of them re-reads the system file. It refers to
no front-end type: kind settings are resolved into each kind's config, plots and records into
port references, checks into resolved expression trees, the ROS 2 section into a plan. Runtime state (FMU instances, ORT sessions,
buffers) lives in runtime objects, never here.
"""

from __future__ import annotations

import dataclasses
import enum
import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from fmionnx.compile.checkir import Check
from fmionnx.core.diagnostics import Span
from fmionnx.core.types import (
    Component,
    Port,
    PortRef,
    Scalar,
    ValueSource,
)
from fmionnx.core.units import UnitConversion
from fmionnx.kinds.base import SceneMap

if TYPE_CHECKING:
    from fmionnx.compile.ros2.types import Ros2Plan, Ros2Settings


@dataclass(frozen=True, slots=True)
class InputTarget:
    """A settable port a system input reaches: ``value * factor + offset`` is set on it."""

    ref: PortRef
    factor: float = 1.0
    offset: float = 0.0


@dataclass(frozen=True, slots=True)
class SystemInput:
    """A named input of the whole system (``inputs:``; an open SSP system connector).

    Nothing drives it during a run: ``--param NAME=value`` sets the parameters or input start
    values of the ports it reaches, each through its own linear transformation, so that a
    system from another tool keeps the names its author gave its inputs.
    """

    name: str
    targets: tuple[InputTarget, ...]
    span: Span | None = None
    #: The value it holds without ``--param``: a value bound to an SSP connector that leads
    #: to no component connector (kept as OMSimulator keeps it); None: unset.
    value: Scalar | None = None
    #: Where ``value`` came from.
    source: ValueSource | None = None


@dataclass(frozen=True, slots=True)
class Connection:
    """A checked edge from an output element range to an input element range.

    ``size`` elements flow; when an index is given on an end, exactly one element is taken
    or written there. ``factor``/``offset`` apply ``y = factor * x + offset``: the whole
    transformation the runtime applies, i.e. the automatic unit conversion (``units``, when
    the ends' units differ) followed by the connection's own factor and offset (SSP
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
    units: UnitConversion | None = None

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
    #: Seconds between two recorded rows (a whole multiple of ``step``); None: every step.
    output_interval: float | None = None

    @property
    def output_every(self) -> int:
        """Base steps between two recorded rows (1 without an output interval)."""
        if self.output_interval is None:
            return 1
        return max(1, round(self.output_interval / self.step))

    @property
    def steps(self) -> int:
        """Number of base steps from start to stop."""
        return round((self.stop - self.start) / self.step)

    def time_at(self, n: int) -> float:
        """Time of communication point ``n``, computed, never accumulated."""
        return self.start + n * self.step


#: What a plot's ``file`` may be: one plain file name, written inside ``--out``. No folders, no
#: ``..``, no absolute path, no hidden name: a system file (or a supplier's SSP) must not be able
#: to make ``run`` write anywhere else.
PLOT_FILE_RE = re.compile(r"[A-Za-z0-9_\[\]-][A-Za-z0-9_.\[\]-]{0,127}")


def plot_file_problem(name: str) -> str | None:
    """Why ``name`` cannot be a plot's file name, or None when it can."""
    if PLOT_FILE_RE.fullmatch(name) is None or ".." in name:
        return (
            "a plot file is a plain file name (letters, digits, `_`, `-`, `.`, at most 128), "
            "written inside the output folder: no folders, `..` or absolute paths"
        )
    return None


@dataclass(frozen=True, slots=True)
class Series:
    """One signal a plot draws, resolved: as written, its results columns, its unit.

    ``columns`` are the results columns the signal fills: one for a scalar, an element or a
    ``[1]``-shaped port, one per element of an array (a line each in a time plot).
    """

    signal: str
    columns: tuple[str, ...]
    unit: str | None = None

    @property
    def label(self) -> str:
        """``odometry.posX [m]``: the signal with its declared unit, for axes and legends."""
        return f"{self.signal} [{self.unit}]" if self.unit else self.signal


@dataclass(frozen=True, slots=True)
class Marks:
    """Marks of a time plot: where ``column`` changes value, each new value's ``labels``
    entry (value, text), else ``signal = value``."""

    signal: str
    column: str
    labels: tuple[tuple[float, str], ...] = ()

    def label(self, value: float) -> str:
        """What the mark of a change to ``value`` says."""
        for known, text in self.labels:
            if known == value:
                return text
        return f"{self.signal} = {value:g}"


@dataclass(frozen=True, slots=True)
class Plot:
    """A plot ``run`` draws, resolved: an x-y trajectory (``xy``) or signals over time (``y``).

    ``xy``/``y`` are the signals as written; ``series`` the same signals resolved to results
    columns and units; ``refs`` the ports they read (recorded so that they can be drawn).
    What an xy plot draws underneath is resolved too, so that drawing needs no model file:
    ``path`` the expected path's points, ``scene`` the map of the component's world (its sites
    and fixed shapes). ``file`` is the image's name inside the output folder, always set by
    the compiler (given, or derived from the title). ``marks``: a time plot's marks where a
    discrete signal changes (its port is among ``refs``, so it is recorded).
    """

    xy: tuple[str, str] | None = None
    y: tuple[str, ...] = ()
    refs: tuple[PortRef, ...] = ()
    series: tuple[Series, ...] = ()
    path: tuple[tuple[float, float], ...] = ()
    scene: SceneMap | None = None
    title: str | None = None
    file: str | None = None
    marks: Marks | None = None


#: How an algebraic loop is iterated (``run.algebraic_loops.solver``).
LoopMethod = Literal["fixed-point", "newton"]


@dataclass(frozen=True, slots=True)
class LoopSolver:
    """The resolved ``run.algebraic_loops`` settings one loop is iterated with."""

    method: LoopMethod = "fixed-point"
    tolerance: float = 1e-10
    max_iterations: int = 50
    relaxation: float = 1.0


@dataclass(frozen=True, slots=True)
class AlgebraicLoop:
    """A cycle through direct-feedthrough ports that the run solves by iteration.

    ``members``: the components whose ports form the loop (a strongly connected part of the
    feedthrough graph, loops sharing a component merged), in the order one iteration steps
    them; they are consecutive in :attr:`CompiledSystem.order` and share one period.
    ``tears``: the inputs iterated, i.e. the destinations of the loop's connections from a
    member to one stepped before it (each reads the previous iteration's value). ``cycle``:
    one cycle of the loop as ``component.port`` names, for messages.
    """

    members: tuple[str, ...]
    tears: tuple[PortRef, ...]
    cycle: tuple[str, ...]
    solver: LoopSolver

    @property
    def label(self) -> str:
        """``a.y -> b.u -> b.y -> a.u -> a.y``: how messages name the loop."""
        return " -> ".join([*self.cycle, self.cycle[0]]) if self.cycle else "+".join(self.members)


@dataclass(frozen=True, slots=True)
class CompiledSystem:
    """The whole checked system. Immutable; make a new one with ``dataclasses.replace``."""

    name: str
    source: Path
    run: RunSettings
    components: tuple[Component, ...]
    connections: tuple[Connection, ...]
    order: tuple[str, ...]
    plots: tuple[Plot, ...] = ()
    record: tuple[PortRef, ...] = ()
    checks: tuple[Check, ...] = ()
    ros2: Ros2Settings | None = None
    ros2_plan: Ros2Plan | None = None
    description: str = ""
    inputs: tuple[SystemInput, ...] = ()
    #: Algebraic loops solved by iteration (``run.algebraic_loops``); empty without loops.
    loops: tuple[AlgebraicLoop, ...] = ()

    def loop_of(self, name: str) -> AlgebraicLoop | None:
        """The iterated algebraic loop component ``name`` belongs to, if any."""
        for loop in self.loops:
            if name in loop.members:
                return loop
        return None

    def component(self, name: str) -> Component:
        """The component called ``name`` (KeyError when absent)."""
        for component in self.components:
            if component.name == name:
                return component
        raise KeyError(name)

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
                    "config": dataclasses.asdict(c.config),
                    "external": c.external,
                    "parameters": [[p.port, list(p.value)] for p in c.parameters],
                }
                for c in self.components
            ],
            "connections": [[str(c.src), str(c.dst), c.factor, c.offset] for c in self.connections],
            "order": list(self.order),
        }
        if self.inputs:  # absent when empty: the hashes of systems without inputs stay as they were
            payload["inputs"] = [
                [i.name, [[str(t.ref), t.factor, t.offset] for t in i.targets]]
                + ([i.value] if i.value is not None else [])
                for i in self.inputs
            ]
        if self.loops:  # only then: the hashes of systems without loops stay as they were
            payload["loops"] = [dataclasses.asdict(loop) for loop in self.loops]
        text = json.dumps(payload, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()
