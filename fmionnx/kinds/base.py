"""The contract every component kind implements: one plug-in object per kind.

A kind owns everything about its components: the system-file fragment (a pydantic model), the
interface reader, the compile-time resolution of that fragment into a frozen config, the runner
factory, the SSP MIME type, how ``graph`` draws it and what it can do (capabilities). The table
in :mod:`fmionnx.kinds.registry` lists the kinds; no other module names one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from fmionnx.core.codes import ErrorCode
from fmionnx.core.errors import FmionnxError
from fmionnx.core.types import Component, ComponentInterface, KindConfig, Port, Scalar

if TYPE_CHECKING:  # the runner contract brings numpy: loaded when a runner is made
    from fmionnx.core.modelfiles import ModelFile
    from fmionnx.core.runner import Runner, Wiring
    from fmionnx.core.specbase import ComponentSpecBase  # pydantic: only where specs are read

#: The kind steps a physics simulation: its timestep bounds the base step, it drives the ROS 2
#: clock in free runs, and its ``base_quat`` outputs are (w, x, y, z) quaternions.
SIMULATOR = "simulator"
#: The kind produces camera images (lazy outputs rendered only when a consumer is due).
CAMERA = "camera"
#: An FMI model: SSP connector names are its own variable names (``a.b[2]``) and the SSP
#: ``implementation`` attribute selects its interface type.
FMI = "fmi"
#: The model names fixed points of its world (MuJoCo sites) that checks measure distances to
#: (``distance(..., to=world.site.B)``): the kind implements :class:`SiteSource`.
SITES = "sites"
#: The model has a map: its fixed landmarks seen from above (named sites, visible static
#: shapes in their colours), which trajectory plots draw underneath: the kind implements
#: :class:`MapSource`.
MAP = "map"
#: The model has no time of its own (a learned function): run alone, it is one step of 1 s
#: (``fmionnx run model.onnx`` infers it once); other lone models run their own experiment.
TIMELESS = "timeless"
#: The model has no state: its outputs at the start time are computed from its connected
#: inputs at the start time (its runner implements
#: :class:`fmionnx.core.runner.StartEvaluating`), so a backend hands it those inputs at
#: initialization, and a lazy output it reads (a camera) is made at the start time too.
EVALUATED_AT_START = "evaluated-at-start"
#: The interface's content hash is the sha256 of the model file's bytes (a model read from
#: one file, not a folder): the compile cache keeps a compile only when the file it hashes for
#: the entry is the file the interface was read from (:mod:`fmionnx.pipeline.compilecache`).
FILE_HASHED = "file-hashed"

#: A fact (``"true"``) of a model that reads files its content hash does not cover (an ONNX
#: model's external tensor data): the compile cache keeps no compile or check of it, and it
#: is read every time.
UNLISTED_FILES = "externalData"


@dataclass(frozen=True, slots=True)
class KindProblem:
    """A problem a kind finds in a component entry; ``key`` is the entry key to point at."""

    code: ErrorCode
    message: str
    key: str
    hint: str | None = None


@dataclass(frozen=True, slots=True)
class Site:
    """A named point of a model's world, in metres.

    ``position`` is where it is when the model is loaded; ``moves_with`` names the body that
    carries it when that body can move (then the position is not a fixed landmark).
    """

    position: tuple[float, float, float]
    moves_with: str | None = None


@runtime_checkable
class SiteSource(Protocol):
    """A kind whose models name sites (declared by the :data:`SITES` capability)."""

    def sites(self, path: Path) -> Mapping[str, Site]:
        """The named sites of the model at ``path`` (raises ModelError when unreadable)."""
        ...


#: A colour as red, green, blue, alpha, each from 0 to 1 (MuJoCo's ``rgba``).
Rgba = tuple[float, float, float, float]


@dataclass(frozen=True, slots=True)
class MapSite:
    """A named fixed point of a model's world on the ground plane (metres): ``A``, ``B``."""

    name: str
    x: float
    y: float
    rgba: Rgba


@dataclass(frozen=True, slots=True)
class MapShape:
    """A fixed, visible part of a model's world seen from above: a sign board, a wall.

    ``outline`` is its footprint on the ground plane, a convex polygon (counter-clockwise,
    metres); ``top`` its highest point, so that what stands higher is drawn over what it
    hides, as seen from above. ``label``: what the landmark means, when the model says
    (a sign board's "turn left"), for a plot's legend.
    """

    name: str
    outline: tuple[tuple[float, float], ...]
    rgba: Rgba
    top: float
    label: str | None = None


@dataclass(frozen=True, slots=True)
class SceneMap:
    """The fixed landmarks of a model's world, as a plot draws them under a trajectory.

    Plain numbers only: it is resolved at compile time and kept in the compiled system, so
    that drawing a plot needs neither the model file nor the kind's library.
    """

    sites: tuple[MapSite, ...] = ()
    shapes: tuple[MapShape, ...] = ()


@runtime_checkable
class MapSource(Protocol):
    """A kind whose models have a map (declared by the :data:`MAP` capability)."""

    def scene_map(self, path: Path) -> SceneMap:
        """The map of the model at ``path`` (raises ModelError when unreadable)."""
        ...


@runtime_checkable
class Repeatable(Protocol):
    """A kind whose components can repeat a step from a saved state.

    Iterating an algebraic loop (``run.algebraic_loops``) steps each member from the same
    communication point again and again until the exchanged values converge; that needs every
    member to save its state before the first try and go back to it before the next. Their
    runners then implement :class:`fmionnx.core.runner.StateSaving`. A kind that does not
    implement this protocol cannot be part of an iterated loop (E051).
    """

    def repeat_problem(self, component: Component) -> str | None:
        """Why ``component`` cannot repeat a step from a saved state, or None when it can."""
        ...


@runtime_checkable
class ResultNames(Protocol):
    """A kind whose lone model names its results by the model's own variables.

    ``fmionnx run model.fmu`` writes ``x``, not ``model.x``, and an FMI 2 array keeps its
    scalar variables' names (``w[1]``), as ``fmpy simulate`` does. A kind without this
    protocol names a lone model's columns by port (``port``, ``port[i]``).
    """

    def result_aliases(self, component: Component) -> dict[str, str]:
        """Results column (``comp.port``, ``comp.port[i]``) -> the name a lone model's
        results use, for every output of ``component``."""
        ...


@runtime_checkable
class ShipsFiles(Protocol):
    """A kind whose model needs files beside it (a scene's includes, meshes, textures).

    ``compile --models``, ``export`` and ``sweep`` ship what :meth:`model_files` lists, copied
    by :func:`fmionnx.core.modelfiles.copy_model_files` (regular files inside the model's
    folder, bounded): never the model's whole folder, which may hold anything. Such a model
    travels in a folder of its own (an SSP's ``resources/<component>/``). A kind without it
    ships its model file alone, or an unpacked model folder's files.
    """

    def model_files(self, path: Path) -> tuple[ModelFile, ...]:
        """The files the model at ``path`` needs, itself included, named relative to its
        folder (ShippingError when one reaches outside it or is no regular file)."""
        ...


@runtime_checkable
class WorkerSettings(Protocol):
    """A kind with process-wide settings for a process that runs many runs, each beside
    others on the machine's other cores (a study's worker).

    A study's parallelism is across its cases: a case that fans out (a thread pool per core)
    takes a core from another case, and what a model loads once can serve the next cases.
    """

    def for_workers(self) -> None:
        """Apply the settings to this process (idempotent)."""
        ...


@runtime_checkable
class SharedProcess(Protocol):
    """A kind that says whether a model's process may serve its next run.

    A study's worker keeps an isolated model's process for the next case of the same model
    (:func:`fmionnx.runtime.isolated.proxy.keep_children`) and makes a new instance there;
    a model that must not be instantiated twice in one process gets a fresh process instead.
    A kind without this protocol allows it.
    """

    def process_reusable(self, component: Component) -> bool:
        """Whether another run of ``component`` may use the process its last run ended in."""
        ...


@runtime_checkable
class WarmUp(Protocol):
    """A kind whose runners' imports are worth paying before a model is loaded (an isolated
    model's process forks from a zygote that has done them)."""

    def warm_up(self) -> None:
        """Import what this kind's runners need."""
        ...


@runtime_checkable
class ConfinedStart(Protocol):
    """A kind whose runner, to start, would run a process of its own.

    A model confined by ``--sandbox`` can start no process (docs/security.md): what the
    runner would find out that way (MuJoCo probes which OpenGL backend works in a child
    process) is found by the process that starts the confined one, and handed to it in its
    environment.
    """

    def confined_environment(self, component: Component) -> Mapping[str, str]:
        """Environment variables that settle, for a confined process, what the runner of
        ``component`` would otherwise find out by starting a process (empty: nothing)."""
        ...


@runtime_checkable
class SizingParameters(Protocol):
    """A kind whose parameters may size other ports: an FMI 3 structural parameter that is the
    ``<Dimension>`` of an array port.

    A compiled port has one shape, the one the model declares by default (the parameter's
    start value), and every runner, connection and recording is sized from it; a value that
    changed the parameter would have the model read and write arrays of another size. The
    compiler refuses such a value where it is set (:func:`fixed_size_problem`). A kind without
    this protocol has no parameter that sizes a port.
    """

    def sized_ports(self, interface: ComponentInterface, name: str) -> tuple[str, ...]:
        """The ports of ``interface`` whose shape the parameter ``name`` sets (empty: none)."""
        ...


def fixed_size_problem(
    kind: object, interface: ComponentInterface, port: Port, values: tuple[Scalar, ...]
) -> str | None:
    """Why ``values`` cannot be set on ``port`` of a model of ``kind``: it sizes other ports
    (:class:`SizingParameters`) and differs from its start value, with which they were sized.
    None when it sizes none or keeps that value."""
    if not isinstance(kind, SizingParameters):
        return None
    sized = kind.sized_ports(interface, port.name)
    if not sized or values == port.start:
        return None
    shapes = ", ".join(f"`{name}`{_shape_of(interface, name)}" for name in sized)
    start = "no value" if port.start is None else f"its start value {_values(port.start)}"
    return (
        f"`{port.name}` is a structural parameter that sizes {shapes}; fmionnx fixes a "
        f"model's arrays at their default shape, so `{port.name}` can only keep {start} "
        f"(got {_values(values)})"
    )


def _shape_of(interface: ComponentInterface, name: str) -> str:
    port = interface.port(name)
    return "" if port is None else f" (shape {port.shape_text()})"


def _values(values: tuple[Scalar, ...]) -> str:
    return str(values[0]) if len(values) == 1 else "[" + ", ".join(map(str, values)) + "]"


#: A value a study gives one of a kind's settings: a number, or a flat list (a position).
SettingInput = Scalar | tuple[Scalar, ...]


class SettingError(FmionnxError):
    """A value (or a name) that one of a kind's settings refuses; the message says why."""


@runtime_checkable
class Settable(Protocol):
    """A kind whose components have settings a study can vary besides model parameters.

    A ``signal``'s waveform numbers, a scene's values: things of the resolved config rather
    than ports of the model. A study target ``component.setting`` names one; the study
    compiler asks :meth:`settings` for the names (its "did you mean") and :meth:`with_setting`
    for the new config, which it puts into the case's compiled system. ``with_setting`` is a
    pure function checked with the rules the kind applies at compile time, so a worker that
    derives a case's system from the base gets the same result, or the same refusal.
    """

    def settings(self, component: Component) -> tuple[str, ...]:
        """The names of ``component``'s settings (raises ModelError when its model is
        unreadable)."""
        ...

    def with_setting(self, component: Component, name: str, value: SettingInput) -> KindConfig:
        """``component``'s config with setting ``name`` at ``value`` (SettingError when the
        name is unknown or the value is refused)."""
        ...

    def setting_hint(self, component: Component, name: str) -> str | None:
        """Why ``name`` is not one of ``component``'s settings when the kind knows better than
        a "did you mean" (a body that moves, a table's values), else None."""
        ...


@dataclass(frozen=True, slots=True)
class Display:
    """How ``fmionnx graph`` draws a kind: label, DOT node attributes, Mermaid brackets."""

    label: str
    dot: str
    mermaid: tuple[str, str]
    colour: str


@dataclass(frozen=True, slots=True)
class RoleDefault:
    """A ROS 2 default for a well-known port of a kind: topic suffix, message type, fields."""

    topic: str
    msgtype: str
    fields: tuple[str, ...]


class ComponentKind(Protocol):
    """One kind of component (``fmu``, ``onnx``, ``mujoco``, ``signal``).

    ``read_interface`` reads the model file's real interface and raises
    :class:`fmionnx.core.errors.ModelError` (with a diagnostics code) when the file is missing,
    unreadable or unsupported. ``spec`` may be None (``fmionnx inspect`` on a bare file); kinds
    whose ports depend on options (MuJoCo camera sizes) then use their defaults. Heavy
    libraries are imported inside methods so that ``validate`` stays fast.
    """

    @property
    def name(self) -> str:
        """Key of the kind in system files (``kind: fmu``)."""
        ...

    @property
    def spec_model(self) -> type[ComponentSpecBase]:
        """The pydantic model of this kind's component entry."""
        ...

    @property
    def config_type(self) -> type[KindConfig]:
        """The frozen dataclass :meth:`resolve` returns (read back from serialised systems)."""
        ...

    @property
    def suffixes(self) -> tuple[str, ...]:
        """File name endings recognised by ``fmionnx inspect``."""
        ...

    @property
    def summary(self) -> str:
        """One line for help texts."""
        ...

    @property
    def mime_type(self) -> str:
        """The SSP ``Component type`` of this kind."""
        ...

    @property
    def capabilities(self) -> frozenset[str]:
        """What the kind can do (:data:`SIMULATOR`, :data:`CAMERA`, :data:`FMI`, ...)."""
        ...

    @property
    def libraries(self) -> tuple[str, ...]:
        """Distributions whose versions ``run.json`` records (they decide the kind's results)."""
        ...

    @property
    def display(self) -> Display:
        """How ``graph`` draws the kind."""
        ...

    @property
    def ros2_defaults(self) -> Mapping[tuple[str, str], RoleDefault]:
        """ROS 2 topic defaults by (port name, causality) for well-known ports."""
        ...

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the interface of the model at ``path``."""
        ...

    def check(
        self, spec: ComponentSpecBase, interface: ComponentInterface
    ) -> tuple[KindProblem, ...]:
        """Problems of an entry that only the kind can see (an FMU without a usable binary)."""
        ...

    def validate_model(self, path: Path, interface: ComponentInterface) -> tuple[KindProblem, ...]:
        """Deeper checks of a lone model file (``fmionnx validate model.fmu``) whose interface
        was read: its format's own validator (FMPy, the ONNX checker) and what the kind needs
        to run it. A system's validation skips them: they cost more than reading an interface.
        """
        ...

    def resolve(self, spec: ComponentSpecBase, interface: ComponentInterface) -> KindConfig:
        """The resolved, frozen configuration of a checked component entry."""
        ...

    def make_runner(self, component: Component, wiring: Wiring) -> Runner:
        """The runtime object of ``component`` (heavy imports happen here, not at import)."""
        ...
