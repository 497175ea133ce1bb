"""The run pipeline: one request, the same stages for every front end and every backend.

``fmionnx run``, :func:`fmionnx.run`, ``System.run`` and a study's cases hand a
:class:`~fmionnx.pipeline.request.RunRequest` to :func:`execute`, which goes through the
stages in this order and returns a :class:`~fmionnx.pipeline.outcome.RunOutcome`:

1. **outputs** — ``--out`` and ``--record`` are usable, checked before anything is compiled:
   learning after minutes of simulation that the results cannot be written is too late;
2. **load** — the system file, compiled system or single model is compiled
   (:mod:`~fmionnx.pipeline.system`);
3. **overrides** — ``--stop-time``, ``--param``, ``--output-interval`` make a new compiled
   system; then the run's size is held against ``--max-steps`` and the default results
   folder (``out/<system name>/``) is chosen and checked;
4. **safety** — the backend settles what depends on the system (in-process: ``--isolate``'s
   default, docs/security.md) and says what would stop it (:meth:`Backend.validate`);
5. **backend** — the backend runs; checkpoints, an abandoned run's results, observers'
   progress, the live views' feed (:mod:`~fmionnx.pipeline.feed`), statistics
   (``--profile``) and the non-finite guard's policy are wired in here;
6. **checks** — the system's ``checks:`` are evaluated on the recorded signals;
7. **results** — ``results.csv``, ``run.json`` and plots are written; the exit status is
   decided.

Refusals before the first step raise :class:`~fmionnx.pipeline.errors.PipelineError` (with
the CLI's exit status) or, for errors in the system file, DiagnosticError; a fault during the
run is the outcome's status, with everything recorded up to it written.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Unpack

from fmionnx.compile.overrides import OverrideError
from fmionnx.core.diagnostics import Severity
from fmionnx.core.errors import DiagnosticError, FmionnxError
from fmionnx.core.types import PortRef
from fmionnx.pipeline.backends import backend_entry
from fmionnx.pipeline.errors import RefusedError, RequestError
from fmionnx.pipeline.observers import Observers, RunObserver, RunStart
from fmionnx.pipeline.outcome import RunOutcome, exit_status
from fmionnx.pipeline.outputs import (
    check_distinct_outputs,
    check_output_file,
    check_recording_file,
    check_results_folder,
    undone_on_failure,
)
from fmionnx.pipeline.request import RunRequest, RunSettings, build_request
from fmionnx.runtime.backend import Backend, BackendOptions, OptionsError, RunContext
from fmionnx.runtime.instruments import Instruments
from fmionnx.runtime.result import ProgressCallback, RunOptions, RunResult
from fmionnx.runtime.stopping import late_stop_text, stops_held

LOG = logging.getLogger("fmionnx.pipeline")

#: What a Python caller names the signals to record with: ``"component.port"`` (an element
#: ``"component.port[i]"``; a single FMU's variable by its name) or a PortRef.
SignalNames = str | PortRef | Sequence[str | PortRef]

if TYPE_CHECKING:
    from fmionnx.pipeline.feed import Feeder
    from fmionnx.pipeline.system import System
    from fmionnx.results.csvahead import CsvAhead
    from fmionnx.results.mcap_record import McapRecorder
    from fmionnx.results.plotworker import PlotWorker
    from fmionnx.runtime.recorder import FrameSink


def execute(
    request: RunRequest,
    observers: Sequence[RunObserver] = (),
    *,
    system: System | None = None,
    signals: SignalNames | None = None,
) -> RunOutcome:
    """Run ``request`` through every stage (module docstring); ``system`` skips loading (a
    system already loaded, ``System.run``); ``signals`` narrows what is recorded (names
    resolved once the system is loaded: :func:`chosen_signals`).

    A single ``.onnx`` model, given by its path or loaded, is inferred once, as ``fmionnx run
    model.onnx`` does (:mod:`~fmionnx.pipeline.infer`): a loaded one without ``inputs`` was
    run over time instead (a bug hunt), two answers to one question."""
    if request.kind == "inference":
        return _inferred(request, observers, system, signals)
    views = _views(request)  # a missing library or viewer: refused before any folder is made
    try:
        with undone_on_failure():  # an empty results folder made for a run that failed to start
            outcome, late = _checked_and_run(request, views, observers, system, signals)
    except BaseException as exc:  # on every path: a view's server and recording let go
        Observers([*views, *observers]).failed(exc)
        raise
    if late:
        LOG.warning("%s", late_stop_text(late[0]))
    return outcome


def _checked_and_run(
    request: RunRequest,
    views: list[RunObserver],
    observers: Sequence[RunObserver],
    system: System | None,
    signals: SignalNames | None,
) -> tuple[RunOutcome, list[str]]:
    _check_outputs(request)
    watch = Observers([*views, *observers])  # a view's files are closed before they are named
    fed = [o for o in (*views, *observers) if o.wants_feed]  # a caller's own view too
    if system is None:
        system = load_request(request)
    chosen = chosen_signals(system, signals)
    watch.loaded(system)
    system = _overridden(system, request)
    out = _results_folder(system, request)
    backend = backend_entry(request.backend)()
    recorder = _mcap_recorder(request, backend, system)
    options = _prepared(backend, system, request, recording=recorder is not None, viewing=bool(fed))
    backend.start_helpers(system.compiled, options)  # before the plot worker and any thread
    ahead = _csv_ahead(system, options, out)
    feeder = _feeder(system, fed)
    if feeder is not None:
        watch = Observers([watch, feeder])
    run = _run_options(request, system, options, out, watch, chosen)
    run = _watched(run, request, recorder, feeder)
    run = dataclasses.replace(run, follower=ahead)
    start = RunStart(
        system, backend.name, options.where(), options.how(), options.publishes_rows, out
    )
    # Rows formatted ahead by nothing else, and recorded by the master's own recorder (the
    # live views' feed brings its own): the plot worker follows them.
    plotter = _plot_worker(
        system, request, out, backend, follow=ahead is None and run.instruments is None
    )
    if plotter is not None and plotter.rows is not None:  # it formats results.csv meanwhile
        run = dataclasses.replace(run, instruments=Instruments(recorder=plotter.rows.recorder))
    late: list[str] = []
    # Entered once the backend returned, left last: from the run's last step on, a stop
    # signal cuts nothing off (the results, the checks, the plot worker's end).
    with contextlib.ExitStack() as after_loop:
        try:
            watch.before_run(start)
            try:
                result = backend.run(system.compiled, options, run)
                late = after_loop.enter_context(stops_held())
                if feeder is not None:
                    feeder.flush(result.steps_done)  # the rows the loop had not handed on yet
            except (DiagnosticError, FmionnxError) as exc:
                if recorder is not None:
                    recorder.finish(None)
                message = (
                    exc.diagnostics[0].message if isinstance(exc, DiagnosticError) else str(exc)
                )
                raise RefusedError(message) from exc  # e.g. DDS refusing, a swapped library
            finally:
                watch.after_run()
            outcome = _finish(request, system, result, out, recorder, ahead, watch, plotter)
        finally:
            if plotter is not None:
                plotter.close()
    return outcome, late


def _inferred(
    request: RunRequest,
    observers: Sequence[RunObserver],
    system: System | None,
    signals: SignalNames | None,
) -> RunOutcome:
    """One inference: no run over time, so nothing to record, watch or check; observers hear
    only that it finished."""
    from fmionnx.pipeline.infer import inference_outcome

    if signals is not None:
        msg = "`signals` chooses what a run over time records, not a single ONNX inference's"
        raise RequestError(msg)
    with undone_on_failure():
        _check_outputs(request)
        outcome = inference_outcome(request, system)
    Observers(observers).finished(outcome)
    return outcome


def load_request(request: RunRequest) -> System:
    """The request's target, loaded (DiagnosticError for errors in it; RequestError for
    ``--step``/``--start-time`` on a compiled system)."""
    from fmionnx.pipeline.system import load

    overrides = request.overrides
    try:
        return load(
            request.target, interface=overrides.interface if request.kind == "model" else None,
            step=overrides.step, start=overrides.start_time, models=overrides.models,
            # compiled in only with a new start (one past the file's stop then compiles);
            # alone it stays an override of the compiled system, kept apart in the cache
            stop=overrides.stop_time if overrides.start_time is not None else None,
        )  # fmt: skip
    except OverrideError as exc:
        raise RequestError(str(exc)) from None
    except FmionnxError as exc:  # the compiled-system module loads only when one was read
        from fmionnx.compile.systemfile import CompiledFileError

        if isinstance(exc, CompiledFileError):  # refused: said as `node` says it, one line
            raise RefusedError(str(exc)) from None
        raise


def chosen_signals(system: System, signals: SignalNames | None) -> tuple[PortRef, ...] | None:
    """``signals`` resolved against ``system`` as a system file's ``record:`` is; the first
    one that names no port is refused (RequestError naming it), not a KeyError mid-run."""
    if signals is None:
        return None
    # Only now: the resolver's module loads the system file's models (pydantic), which a
    # run read back from the compile cache does not (tests/cli/test_startup_imports.py).
    from fmionnx.compile.endpoints import endpoint_text, resolve_endpoint
    from fmionnx.core.diagnostics import DiagnosticBag, Span

    given = [signals] if isinstance(signals, str | PortRef) else list(signals)
    interfaces = {c.name: c.interface for c in system.compiled.components}
    by_alias = {alias: name for name, alias in system.aliases.items()}
    chosen = []
    for item in given:
        if not isinstance(item, str | PortRef):
            msg = f"signals: `{item!r}` is not a signal: name it `component.port` (a string)"
            raise RequestError(msg)
        # a PortRef as an endpoint is written: its port quoted when that is no dotted word
        text = by_alias.get(str(item), item if isinstance(item, str) else endpoint_text(item))
        bag = DiagnosticBag()
        resolved = resolve_endpoint(text, Span(Path(system.name)), interfaces, bag)
        if resolved is None:
            problem = next(iter(bag))
            hint = f"; {problem.hint}" if problem.hint else ""
            raise RequestError(f"signals: `{item}`: {problem.message}{hint}")
        chosen.append(resolved.ref)
    return tuple(chosen)


def run_system(
    system: System,
    *,
    signals: SignalNames | None = None,
    progress: ProgressCallback | None = None,
    observers: Sequence[RunObserver] = (),
    **settings: Unpack[RunSettings],
) -> RunOutcome:
    """Run a loaded ``system`` with ``fmionnx run``'s options and defaults (``System.run``).

    Without ``out`` nothing is written (a Python caller asks for a folder); options that
    need the system file (``step``, ``start_time``, ``interface``) are refused: pass them to
    :func:`~fmionnx.pipeline.system.load`.
    """
    settings.setdefault("no_out", settings.get("out") is None)
    request = loaded_request(system, settings)
    watchers = list(observers)
    if progress is not None:
        watchers.append(_ProgressCall(progress))
    return execute(request, watchers, system=system, signals=signals)


def run_with_options(
    system: System,
    options: RunOptions,
    *,
    signals: SignalNames | None = None,
    progress: ProgressCallback | None = None,
    **settings: Unpack[RunSettings],
) -> RunResult:
    """The in-process master with exactly ``options`` (``System.run(options=...)``): no
    isolation unless they say so, nothing written. ``stop_time`` and ``params`` still apply.
    """
    from fmionnx.backends.inprocess import InProcessBackend

    others = sorted(k for k in settings if k not in ("stop_time", "params"))
    if others:
        msg = f"`{others[0]}` does not combine with `options`: set it in the RunOptions"
        raise RequestError(msg)
    system = system.with_overrides(
        stop_time=settings.get("stop_time"), params=settings.get("params")
    )
    backend = InProcessBackend()
    problems = [
        d
        for d in backend.validate(system.compiled, backend.options_type())
        if d.severity is Severity.ERROR
    ]
    if problems:
        raise DiagnosticError(problems)
    chosen = options
    named = chosen_signals(system, signals)
    record = named if named is not None else system.record
    if record is not None and options.record is None:
        chosen = dataclasses.replace(chosen, record=record)
    if progress is not None:
        chosen = dataclasses.replace(chosen, progress=progress)
    from fmionnx.runtime.master import Master

    result = Master(system.compiled, chosen).run()
    return _aliased(result, system)


# -- stages ------------------------------------------------------------------------------------


def _check_outputs(request: RunRequest) -> None:
    output = request.output
    # The files first: a refused one leaves no results folder made for nothing.
    check_distinct_outputs({"--record": output.record, "--rrd": request.watch.rrd}, output.out)
    if output.record is not None:
        check_output_file(output.record, "--record")
        check_recording_file(output.record, "--record", force=output.force, source=request.target)
    if request.watch.rrd is not None:
        check_output_file(request.watch.rrd, "--rrd")
        check_recording_file(request.watch.rrd, "--rrd", force=output.force, source=request.target)
    if output.out is not None:
        check_results_folder(output.out, force=output.force, system_run=request.kind != "inference")


def _views(request: RunRequest) -> list[RunObserver]:
    """The live views asked for (``--view``, ``--rrd``), their libraries imported now: a
    missing one is refused before anything is compiled."""
    if not request.watch.live:
        return []
    from fmionnx.pipeline.views import ViewerUnreachableError, ViewUnavailableError, make_views

    try:
        return make_views(request.watch.views, request.watch.rrd)
    except ViewUnavailableError as exc:
        raise RequestError(str(exc)) from None
    except ViewerUnreachableError as exc:
        raise RefusedError(str(exc)) from None


def _feeder(system: System, views: list[RunObserver]) -> Feeder | None:
    if not views:
        return None
    from fmionnx.pipeline.feed import Feeder

    return Feeder(system.compiled, Observers(views))


def _watched(
    run: RunOptions, request: RunRequest, recorder: McapRecorder | None, feeder: Feeder | None
) -> RunOptions:
    """``run`` with the watching wired in: statistics, the non-finite policy, the frames'
    sinks (the recording, the views) and the views' recorder."""
    watch = request.watch
    run = dataclasses.replace(
        run, profile=watch.profile, on_nonfinite=watch.on_nonfinite, frames=recorder
    )
    if feeder is None:
        return run
    from fmionnx.pipeline.feed import FrameFanout
    from fmionnx.runtime.instruments import Instruments

    sinks: list[FrameSink] = [feeder.views] if recorder is None else [recorder, feeder.views]
    taken = feeder.recorder
    return dataclasses.replace(
        run, frames=FrameFanout(sinks), instruments=Instruments(recorder=lambda: taken)
    )


def _overridden(system: System, request: RunRequest) -> System:
    overrides = request.overrides
    try:
        system = system.with_overrides(
            stop_time=overrides.stop_time,
            params=dict(overrides.params),
            output_interval=overrides.output_interval,
        )
    except OverrideError as exc:
        raise RequestError(str(exc)) from None
    steps, limit = system.compiled.run.steps, request.limits.max_steps
    if steps > limit:  # after the overrides: --stop-time changes the count
        msg = (
            f"the run is {steps:.3g} base steps, more than --max-steps {limit:.3g}; check "
            "the stop time and step, or pass a larger --max-steps"
        )
        raise RequestError(msg)
    return system


def _results_folder(system: System, request: RunRequest) -> Path | None:
    output = request.output
    if output.out is not None or not output.write:
        return output.out
    from fmionnx.results.outdir import default_folder

    out = default_folder(system.name)  # the system's name is known now; still before the run
    check_distinct_outputs({"--record": output.record, "--rrd": request.watch.rrd}, out)
    check_results_folder(out, force=output.force, system_run=True, default=True)
    return out


def _mcap_recorder(request: RunRequest, backend: Backend, system: System) -> McapRecorder | None:
    record = request.output.record
    if record is None or backend.records_itself:
        return None
    from fmionnx.results.mcap_record import McapRecorder

    return McapRecorder(record, system.compiled)


def _prepared(
    backend: Backend, system: System, request: RunRequest, *, recording: bool, viewing: bool
) -> BackendOptions:
    try:
        options = backend.prepare(
            system.compiled, request.backend_options, RunContext(recording, viewing)
        )
    except OptionsError as exc:
        raise RequestError(str(exc)) from None
    problems = [
        d for d in backend.validate(system.compiled, options) if d.severity is Severity.ERROR
    ]
    if problems:
        raise RefusedError(str(problems[0].message))
    return options


def _run_options(
    request: RunRequest,
    system: System,
    options: BackendOptions,
    out: Path | None,
    watch: Observers,
    signals: tuple[PortRef, ...] | None,
) -> RunOptions:
    """What the backend is handed: recording, limits, checkpoints, the abandon writer."""
    output = request.output
    compiled, aliases = system.compiled, dict(system.aliases)
    details = options.details()

    def checkpoint(result: RunResult) -> None:
        from fmionnx.results import write_results

        assert out is not None
        result.details.update(details)
        write_results(result, compiled, out, aliases=aliases, checkpoint=True)

    def abandon(result: RunResult) -> None:
        result.details.update(details)
        if out is not None:
            from fmionnx.results import write_results

            write_results(result, compiled, out, aliases=aliases, plot_signals=output.plot)
        watch.abandoned(result, out)

    record = signals if signals is not None else system.record
    timeout = request.limits.step_timeout
    return RunOptions(
        record=record, progress=watch.progress if watch.wants_progress else None,
        progress_every=watch.progress_every,
        step_timeout=timeout if math.isfinite(timeout) else None,
        checkpoint=checkpoint if out is not None else None,
        checkpoint_every=output.checkpoint_every, abandon=abandon, out=out,
        record_file=output.record,
    )  # fmt: skip


def _csv_ahead(system: System, options: BackendOptions, out: Path | None) -> CsvAhead | None:
    """A run that publishes its rows while it goes gets results.csv formatted meanwhile."""
    if not options.publishes_rows or out is None:
        return None
    from fmionnx.results.csvahead import CsvAhead, allowed

    if not allowed():
        return None

    return CsvAhead.of(system.compiled)


def _plot_worker(
    system: System, request: RunRequest, out: Path | None, backend: Backend, *, follow: bool
) -> PlotWorker | None:
    """A run that will draw into a results folder starts its plot worker now: matplotlib is
    imported on another core while the run goes on (:mod:`fmionnx.results.plotworker`).

    ``follow``: nothing else formats the run's results.csv ahead, nor records it; if the
    run steps in this process, the worker follows its rows and writes the file
    (:mod:`fmionnx.results.csvfollow`).
    """
    if out is None or not (system.compiled.plots or request.output.plot):
        return None
    from fmionnx.results.plotworker import start

    return start(follow=system.compiled if follow and _follows(backend) else None)


def _follows(backend: Backend) -> bool:
    """Whether ``backend`` steps the run in this process with the master's instruments (the
    in-process backend: its rows can be recorded where a plot worker reads them)."""
    from fmionnx.results.csvfollow import wanted
    from fmionnx.runtime.guardian import BACKEND_NAME

    return backend.name == BACKEND_NAME and wanted()


def _finish(
    request: RunRequest,
    system: System,
    result: RunResult,
    out: Path | None,
    recorder: McapRecorder | None,
    ahead: CsvAhead | None,
    watch: Observers,
    plotter: PlotWorker | None = None,
) -> RunOutcome:
    from fmionnx.runtime.checks import evaluate_checks

    checks = tuple(evaluate_checks(system.compiled.checks, result)) if request.checks else ()
    files: list[Path] = []
    record = request.output.record
    if recorder is not None:
        files.append(recorder.finish(result, checks))
    elif record is not None and record.exists():
        files.append(record)
    rrd = request.watch.rrd
    if rrd is not None:
        files.append(rrd)  # named by its view's ``finished``, after run.json is written
    if out is not None:
        from fmionnx.results import write_results

        files[:0] = write_results(
            result, system.compiled, out, aliases=dict(system.aliases), also=files,
            checks=checks, plot_signals=request.output.plot, ahead=ahead, plotter=plotter,
        )  # fmt: skip
    outcome = RunOutcome(
        system, _aliased(result, system), checks, tuple(files), out, exit_status(result, checks)
    )
    watch.finished(outcome)
    if out is not None and rrd is not None:
        from fmionnx.results import note_finished_files

        note_finished_files(out, [rrd])  # now a file: the folder's record proves it the run's
    return outcome


def _aliased(result: RunResult, system: System) -> RunResult:
    """``result`` with its signals named as results.csv names them (a single FMU's by
    variable)."""
    if system.aliases:
        result.signals = {system.aliases.get(k, k): v for k, v in result.signals.items()}
    return result


class _ProgressCall(RunObserver):
    """A plain ``progress(done, total, time)`` callable as an observer."""

    wants_progress = True

    def __init__(self, call: ProgressCallback) -> None:
        self._call = call

    def progress(self, done: int, total: int, time: float) -> None:
        """Pass it on."""
        self._call(done, total, time)


def run(
    target: str | Path | System,
    /,
    *,
    signals: SignalNames | None = None,
    **settings: Unpack[RunSettings],
) -> RunOutcome:
    """Run ``target`` (a path, or a loaded :class:`System`) as ``fmionnx run`` would;
    ``signals`` narrows what is recorded, as for ``System.run``.

    Every ``fmionnx run`` option is a keyword under its flag's name in snake_case
    (``backend="ros2"``, ``middleware="zenoh"``, ``sync="lockstep"``, ``stop_time=``,
    ``out=``, ``isolate=``, ``checks=`` ...; ``params`` is a mapping), with the same
    defaults: FMUs isolated, results in ``out/<system name>/`` unless ``no_out=True``.
    Raises DiagnosticError for errors in the system file and
    :class:`~fmionnx.pipeline.errors.PipelineError` for a run refused before it started.
    """
    from fmionnx.pipeline.system import System

    if isinstance(target, System):
        return execute(loaded_request(target, settings), system=target, signals=signals)
    return execute(build_request(target, **settings), signals=signals)


def loaded_request(system: System, settings: RunSettings) -> RunRequest:
    """The request to run an already loaded ``system``: options that are applied when a
    system is compiled (``step``, ``start_time``, ``interface``, ``models``) are refused."""
    for name in ("step", "start_time", "interface", "models"):
        if settings.get(name) is not None:
            msg = f"`{name}` is applied when the system is compiled: pass it to fmionnx.load()"
            raise RequestError(msg)
    return build_request(system.source or Path(system.name), **settings)
