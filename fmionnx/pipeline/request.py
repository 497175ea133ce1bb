"""A run request: every choice of ``fmionnx run`` as one typed, immutable value, checked once.

Front ends do not check options themselves: the CLI turns its flags into the same keyword
arguments a Python caller passes (:class:`RunSettings`, the flags' names in snake_case) and
hands them to :func:`build_request`, which converts and checks them (a
:class:`~fmionnx.pipeline.errors.RequestError` names the option as the command line spells
it). The backend's own options are checked by the backend's options type
(:class:`~fmionnx.runtime.backend.BackendOptions`), looked up in the backend table.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal, TypedDict, cast

from fmionnx.compile.overrides import OverrideError, parse_value, plain_value
from fmionnx.core.steps import MAX_RUN_STEPS, time_flags_problem
from fmionnx.core.types import Scalar, is_number
from fmionnx.pipeline.defaults import CHECKPOINT_EVERY, STEP_TIMEOUT
from fmionnx.pipeline.errors import RequestError
from fmionnx.pipeline.viewspec import ViewSpecError, ViewTarget, parse_view
from fmionnx.runtime.backend import BackendOptions, OptionsError

if TYPE_CHECKING:
    from fmionnx.pipeline.system import ParamInput

#: What a request runs: a system file, a compiled system, a single model run over time (an
#: ``.fmu``) or a single model inferred once (an ``.onnx``).
TargetKind = Literal["system", "compiled", "model", "inference"]
#: Compiled-system files (:mod:`fmionnx.compile.systemfile`; the suffix, kept import-free).
COMPILED_SUFFIX = ".fmionnx.json"

ParamValue = Scalar | list[Scalar]


class RunSettings(TypedDict, total=False):
    """Every option of ``fmionnx run``, by its flag's name in snake_case.

    The backend's options (``isolate``, ``sandbox``, ``schedule`` in-process; ``sync``,
    ``ros_distro``, ``middleware``, ``zenoh_router``, ``rtf``, ``input_wait`` for ROS 2) are
    listed too, for type checkers; each backend takes only its own.
    """

    backend: str
    out: str | Path | None
    no_out: bool
    stop_time: float | None
    start_time: float | None
    step: float | None
    output_interval: float | None
    params: Mapping[str, ParamInput] | None  # numpy values too (a ParamValue once checked)
    interface: str | None
    inputs: Mapping[str, str | Path] | None
    record: str | Path | None
    plot: bool
    checks: bool
    force: bool
    checkpoint_every: float
    step_timeout: float
    max_steps: int
    models: str | Path | None
    profile: bool
    on_nonfinite: str
    view: str | Sequence[str] | None
    rrd: str | Path | None
    isolate: str | Sequence[str] | None
    sandbox: bool
    schedule: str | None
    sync: str
    ros_distro: str | None
    middleware: str
    zenoh_router: str
    rtf: float
    input_wait: float


#: The options every backend shares (the rest belong to the chosen backend).
GENERAL = frozenset(
    {
        "backend", "out", "no_out", "stop_time", "start_time", "step", "output_interval",
        "params", "interface", "inputs", "record", "plot", "checks", "force",
        "checkpoint_every", "step_timeout", "max_steps", "models", "profile", "on_nonfinite",
        "view", "rrd",
    }
)  # fmt: skip
#: What a non-finite value on a connection does (``--on-nonfinite``; runtime.transfer's).
NONFINITE_CHOICES = ("fault", "warn")


@dataclass(frozen=True, slots=True)
class Overrides:
    """What replaces the system file's settings: run settings, parameters, the FMU interface."""

    start_time: float | None = None
    step: float | None = None
    stop_time: float | None = None
    output_interval: float | None = None
    params: tuple[tuple[str, ParamValue], ...] = ()
    #: A single FMU only: ``cs`` or ``me`` (None: co-simulation when offered).
    interface: Literal["cs", "me"] | None = None
    #: A compiled system only: the store its models are found in by hash.
    models: Path | None = None


@dataclass(frozen=True, slots=True)
class Output:
    """Where the results go and what they hold."""

    #: The results folder; None: ``out/<system name>/`` when ``write``, else nothing.
    out: Path | None = None
    write: bool = True
    force: bool = False
    #: An MCAP recording of the run (``--record``).
    record: Path | None = None
    #: ``signals.png``: every recorded signal over time (``--plot``).
    plot: bool = False
    checkpoint_every: float = CHECKPOINT_EVERY


@dataclass(frozen=True, slots=True)
class Limits:
    """What keeps a run bounded."""

    step_timeout: float = STEP_TIMEOUT
    max_steps: int = MAX_RUN_STEPS


@dataclass(frozen=True, slots=True)
class Watch:
    """How the run is watched: statistics, the non-finite guard, live views, a recording."""

    #: Per-component statistics (``--profile``): run.json's ``statistics``.
    profile: bool = False
    #: ``fault`` (default) or ``warn``: what a NaN or infinity on a connection does.
    on_nonfinite: Literal["fault", "warn"] = "fault"
    #: Live views the run streams to (``--view``).
    views: tuple[ViewTarget, ...] = ()
    #: A Rerun recording of the run (``--rrd``), written without a viewer.
    rrd: Path | None = None

    @property
    def live(self) -> bool:
        """Whether frames and rows are streamed while the run goes (a view or ``--rrd``)."""
        return bool(self.views) or self.rrd is not None


@dataclass(frozen=True, slots=True)
class RunRequest:
    """One run, checked: what to run, on which backend with which options, what replaces the
    system file's settings, where the results go, the limits, whether checks are evaluated."""

    target: Path
    kind: TargetKind
    backend: str
    backend_options: BackendOptions
    overrides: Overrides = field(default_factory=Overrides)
    output: Output = field(default_factory=Output)
    limits: Limits = field(default_factory=Limits)
    checks: bool = True
    #: A single ONNX model only: a ``.npy`` file per input.
    inputs: tuple[tuple[str, Path], ...] = ()
    watch: Watch = field(default_factory=Watch)


def target_kind(target: Path) -> TargetKind:
    """What ``target`` is, by its name."""
    suffix = target.suffix.lower()
    if suffix == ".fmu":
        return "model"
    if suffix == ".onnx":
        return "inference"
    if target.name.lower().endswith(COMPILED_SUFFIX):
        return "compiled"
    return "system"


def build_request(target: str | Path, **settings: object) -> RunRequest:
    """Check ``settings`` (:class:`RunSettings`) for ``target``; RequestError when one does
    not fit. Options not given take their defaults; ``None`` counts as not given."""
    from fmionnx.pipeline.backends import backend_entry, taken_elsewhere

    given = {k: v for k, v in settings.items() if v is not None}
    path = Path(target)
    kind = target_kind(path)
    backend_name = _text(given.pop("backend", "inprocess"), "--backend")
    backend = backend_entry(backend_name)
    if kind in ("model", "inference") and not backend.runs_single_models:
        msg = f"--backend {backend_name} runs system files, not a single model"
        raise RequestError(msg)
    overrides = _overrides(given, kind)
    output = _output(given, kind)
    limits = _limits(given)
    checks = _flag(given.pop("checks", True), "--checks")
    inputs = _inputs(given.pop("inputs", None), kind)
    watch = _watch(given, kind)
    unknown = sorted(set(given) & GENERAL)
    assert not unknown, unknown  # every general option is taken above
    foreign = set(given) - backend.options_type.names()
    elsewhere = taken_elsewhere(foreign, backend_name) if foreign else {}
    try:
        options = backend.options_type.from_given(given, backend_name, elsewhere)
    except OptionsError as exc:
        raise RequestError(str(exc)) from None
    if watch.live and backend.records_itself:
        msg = (
            f"--view and --rrd show in-process runs; a --backend {backend_name} run's topics "
            "are on the wire: record them with --record, or open them with a ROS 2 viewer"
        )
        raise RequestError(msg)
    return RunRequest(
        path, kind, backend_name, options, overrides, output, limits, checks, inputs, watch
    )


def _overrides(given: dict[str, object], kind: TargetKind) -> Overrides:
    interface = given.pop("interface", None)
    if interface is not None and interface not in ("cs", "me"):
        msg = f"--interface must be `cs` or `me`, not `{interface}`"
        raise RequestError(msg)
    if interface is not None and kind != "model":
        msg = "--interface applies to a single .fmu only"
        raise RequestError(msg)
    times = {
        name: _number(given.pop(name, None), name)
        for name in ("start_time", "step", "stop_time", "output_interval")
    }
    _check_times(times)
    if kind == "inference" and any(
        times[n] is not None for n in ("start_time", "step", "output_interval")
    ):
        msg = (
            "--step, --start-time and --output-interval apply to systems and FMUs, not to a "
            "single ONNX model's inference"
        )
        raise RequestError(msg)
    params = given.pop("params", None) or {}
    if not isinstance(params, Mapping):
        msg = "--param takes `name=value` pairs (from Python: a mapping of names to values)"
        raise RequestError(msg)
    models = given.pop("models", None)
    return Overrides(
        start_time=times["start_time"], step=times["step"], stop_time=times["stop_time"],
        output_interval=times["output_interval"],
        params=tuple((str(k), _param(v)) for k, v in params.items()),
        interface="me" if interface == "me" else "cs" if interface == "cs" else None,
        models=None if models is None else _path(models, "--models"),
    )  # fmt: skip


def _check_times(times: dict[str, float | None]) -> None:
    """A base step and times that cannot be one, refused as options (exit 2): they came as
    errors at the system file, exit 1."""
    problem = time_flags_problem(times["start_time"], times["step"], times["stop_time"])
    if problem is not None:
        raise RequestError(problem)


def _output(given: dict[str, object], kind: TargetKind) -> Output:
    out = given.pop("out", None)
    no_out = _flag(given.pop("no_out", False), "--no-out")
    if out is not None and no_out:
        msg = "--out and --no-out exclude each other"
        raise RequestError(msg)
    plot = _flag(given.pop("plot", False), "--plot")
    if plot and (no_out or kind == "inference"):
        msg = (
            "--plot draws the recorded signals into the results folder: not with --no-out or "
            "a single ONNX model (one call, no signals over time)"
        )
        raise RequestError(msg)
    record = given.pop("record", None)
    if record is not None and kind == "inference":  # it was accepted, and nothing written
        msg = "--record records a run over time, not a single ONNX model's inference"
        raise RequestError(msg)
    every = _number(given.pop("checkpoint_every", CHECKPOINT_EVERY), "checkpoint_every")
    assert every is not None
    if not every >= 0:
        msg = "--checkpoint-every must be >= 0 seconds"
        raise RequestError(msg)
    return Output(
        out=None if out is None else _path(out, "--out"), write=not no_out,
        force=_flag(given.pop("force", False), "--force"),
        record=None if record is None else _path(record, "--record"), plot=plot,
        checkpoint_every=every,
    )  # fmt: skip


def _limits(given: dict[str, object]) -> Limits:
    steps = plain_value(given.pop("max_steps", MAX_RUN_STEPS))
    if isinstance(steps, bool) or not isinstance(steps, int):
        msg = f"--max-steps takes a whole number, not `{steps}`"
        raise RequestError(msg)
    if steps < 1:
        msg = "--max-steps must be at least 1"
        raise RequestError(msg)
    timeout = _number(given.pop("step_timeout", STEP_TIMEOUT), "step_timeout")
    assert timeout is not None
    if not timeout > 0:
        msg = "--step-timeout must be > 0 seconds"
        raise RequestError(msg)
    return Limits(step_timeout=timeout, max_steps=steps)


def _watch(given: dict[str, object], kind: TargetKind) -> Watch:
    profile = _flag(given.pop("profile", False), "--profile")
    policy = given.pop("on_nonfinite", "fault")
    if policy not in NONFINITE_CHOICES:
        msg = f"--on-nonfinite must be `fault` or `warn`, not `{policy}`"
        raise RequestError(msg)
    view = given.pop("view", None)
    if view is not None and not isinstance(view, str | list | tuple):
        msg = "--view takes a view's name (from Python: a string or a list of them)"
        raise RequestError(msg)
    words = [view] if isinstance(view, str) else list(view or ())
    try:
        views = tuple(parse_view(_text(word, "--view")) for word in words)
    except ViewSpecError as exc:
        raise RequestError(str(exc)) from None
    if len({v.kind for v in views}) < len(views):
        msg = "--view names each kind of view once"
        raise RequestError(msg)
    rrd = given.pop("rrd", None)
    if (views or rrd is not None or profile) and kind == "inference":
        msg = "--view, --rrd and --profile watch a run over time, not a single ONNX inference"
        raise RequestError(msg)
    return Watch(
        profile=profile, on_nonfinite="warn" if policy == "warn" else "fault", views=views,
        rrd=None if rrd is None else _path(rrd, "--rrd"),
    )  # fmt: skip


def _inputs(value: object, kind: TargetKind) -> tuple[tuple[str, Path], ...]:
    if not value:
        return ()
    if kind != "inference":
        msg = "--input applies to a single .onnx model only"
        raise RequestError(msg)
    if not isinstance(value, Mapping):
        msg = "--input takes `name=file.npy` pairs (from Python: a mapping of names to files)"
        raise RequestError(msg)
    return tuple((str(name), _path(file, "--input")) for name, file in value.items())


def _param(value: object) -> ParamValue:
    """A ``--param`` value from Python: a numpy number or array, a tuple, taken as the plain
    value it holds (:func:`~fmionnx.compile.overrides.plain_value`); its type is checked
    against the port's when it is set."""
    return cast(ParamValue, plain_value(value))


def _number(value: object, name: str) -> float | None:
    if value is None:
        return None
    value = plain_value(value)  # a numpy number: np.int64(1) is a number of seconds too
    if not is_number(value):
        msg = f"--{name.replace('_', '-')} takes a number, not `{value}`"
        raise RequestError(msg)
    return float(value)


def _flag(value: object, option: str) -> bool:
    if not isinstance(value, bool):
        msg = f"{option} is true or false, not `{value}`"
        raise RequestError(msg)
    return value


def _text(value: object, option: str) -> str:
    if not isinstance(value, str):
        msg = f"{option} takes a name, not `{value}`"
        raise RequestError(msg)
    return value


def _path(value: object, option: str) -> Path:
    if not isinstance(value, str | Path):
        msg = f"{option} takes a path, not `{value}`"
        raise RequestError(msg)
    return Path(value)


def pairs(items: Sequence[str], option: str) -> dict[str, str]:
    """``name=value`` command-line items (``--param``, ``--input``) as a dict."""
    found = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            msg = f"{option} `{item}` must look like `name=value`"
            raise RequestError(msg)
        found[key.strip()] = value.strip()
    return found


def params_from_text(items: Sequence[str]) -> dict[str, ParamValue]:
    """``--param name=value`` items, each value read as JSON (:func:`parse_value`)."""
    try:
        return {k: parse_value(v) for k, v in pairs(items, "--param").items()}
    except OverrideError as exc:
        raise RequestError(str(exc)) from None
