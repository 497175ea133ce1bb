"""ONNX runner: one onnxruntime session, port <-> tensor mapping decided once at setup.

Each input port owns a flat buffer in the tensor's element type; the feed is a reshaped view
of that buffer (no copy per step), e.g. a camera's ``uint8[480,640,3]`` connected to an input
``[1,480,640,3]``. Symbolic dimensions take the sizes the counts fed to the inputs fix, carried
to every port naming them (:mod:`fmionnx.core.dims`); one no input fixes is 1. Outputs are copied into flat
buffers after each run.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from fmionnx.core.dims import Dims, bind_dims, known_count, resolved_shape
from fmionnx.core.runner import Buffer, OutputCopies, fault
from fmionnx.core.types import Causality, Component, DType, Port
from fmionnx.kinds.kept import Kept
from fmionnx.kinds.onnx.kind import OnnxConfig

#: Intra-op threads of a session whose component does not say (None: onnxruntime's default,
#: one per core); see :func:`one_thread_each`.
_default_threads: list[int | None] = [None]


def _drop_session(session: Any) -> None:
    del session  # onnxruntime frees a session with its last reference


#: Sessions kept by a study's worker, by model file and options (:func:`keep_sessions`).
SESSIONS: Kept[tuple[object, ...], Any] = Kept(_drop_session)


def keep_sessions() -> None:
    """From now on, this process keeps a run's session for the next run of the same model
    file with the same options (a study's worker): the model is checked and loaded once."""
    SESSIONS.enable()


def one_thread_each() -> None:
    """From now on, sessions in this process whose component sets no ``threads`` use one.

    onnxruntime's default pool has a spinning thread per core: where every core already runs
    a case of a sweep, those threads take other cases' cores (see docs/sweep.md).
    """
    _default_threads[0] = 1


def concrete_shape(port: Port, size: int | None, dims: Dims | None = None) -> tuple[int, ...]:
    """The tensor shape used at run time: the names ``dims`` fixed (:mod:`fmionnx.core.dims`), an input's
    one other symbolic dimension filled from ``size`` when it divides; any other is 1."""
    resolved = resolved_shape(port, dims if dims is not None else Dims({}), size)
    return tuple(1 if d is None else d for d in resolved)


#: How onnxruntime's arena refuses an allocation beyond its ceiling (bfc_arena.cc).
_CEILING = re.compile(r"Available memory of (\d+) is smaller than requested bytes of (\d+)")


def _over_the_ceiling(text: str) -> str | None:
    """The fault of a run refused by the capped arena (:mod:`.ortsetup`), else None."""
    matched = _CEILING.search(text)
    if matched is None:
        return None
    from fmionnx.core.resources import ONNX_BYTES

    return (
        f"the model needs a tensor of {matched.group(2)} bytes, more than onnxruntime may "
        f"allocate ({ONNX_BYTES.hint()})"
    )


class OnnxRunner:
    """Runs an ONNX model once per step of its component."""

    #: onnxruntime's ``run`` releases the GIL for the whole inference (milliseconds for an
    #: image model), so the master's parallel schedule may step it on a worker thread.
    releases_gil = True
    #: A profiled run (``--profile``) calls its step by what it is: an inference.
    step_phase = "infer"

    def __init__(self, component: Component, sizes: dict[str, int]) -> None:
        self.component = component
        self.lazy_outputs: frozenset[str] = frozenset()
        self._sizes = sizes
        self._session: Any = None
        self._inputs: dict[str, Buffer] = {}
        self._feeds: dict[str, Buffer] = {}
        self._outputs: dict[str, Buffer] = {}
        self._names: list[str] = []
        self._saved: OutputCopies | None = None
        #: The options of every run: their terminate flag stops a run from another thread.
        self._run_options: Any = None
        #: Why the run was stopped (see :meth:`interrupt`), once it was.
        self._stopped: str | None = None
        self._key: tuple[object, ...] | None = None
        self._broken = False

    def instantiate(self) -> None:
        """Create the onnxruntime session with the spec's providers and thread count.

        The model's external data is checked again first (E017), and the sizes of what it
        stores and computes (E008, :mod:`.sizes`): the file may have changed since it was
        compiled, and onnxruntime opens whatever its locations name. A model without external
        data is handed to onnxruntime as the bytes that were checked, and bytes that passed
        before are not checked again (:mod:`.checked`).

        Graph optimisation stops at ``ORT_ENABLE_EXTENDED`` (constant folding, Conv+activation
        and other fusions) instead of onnxruntime's default ``ORT_ENABLE_ALL``, whose extra
        layout pass rewrites convolutions to the blocked NCHWc format: on a per-frame model
        such as the reference sign detector the reorders it inserts made a run several times
        slower (docs/performance.md, "Sign detector and camera rendering").
        """
        from fmionnx.kinds.onnx.ortsetup import onnxruntime_module, session_options

        config = self.component.config
        assert isinstance(config, OnnxConfig)
        threads = config.threads if config.threads is not None else _default_threads[0]
        ort = onnxruntime_module()
        self._run_options = ort.RunOptions()
        # Errors come back as exceptions (and become faults); a stopped run is not logged.
        self._run_options.log_severity_level = 4
        self._key = self._session_key(config, threads)
        if self._key is not None:
            self._session = SESSIONS.take(self._key)
            if self._session is not None:
                return  # made from this very file (its identity is in the key), checked then
        source = self._checked_source()
        options = session_options(ort)
        if threads is not None:
            options.intra_op_num_threads = threads
            options.inter_op_num_threads = 1
        options.log_severity_level = 3
        options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_EXTENDED
        providers = list(config.providers)
        try:
            self._session = ort.InferenceSession(source, sess_options=options, providers=providers)
        except Exception as exc:
            raise fault(
                self.component.name, f"cannot create the session: {exc}", time=0.0
            ) from None

    def _checked_source(self) -> str | bytes:
        """What onnxruntime loads: the model's bytes once they passed the check (now or in an
        earlier run), or its path when it keeps data in external files (checked each time).
        """
        from fmionnx.kinds.onnx import checked
        from fmionnx.kinds.onnx.interface import parse_checked_model, read_model_bytes

        path = self.component.path
        data = read_model_bytes(path)
        if checked.passed(data):
            return data
        from fmionnx.kinds.onnx.external import has_external_data
        from fmionnx.kinds.onnx.sizes import check_model_sizes

        model = parse_checked_model(data, path)
        check_model_sizes(model, path)  # it may have changed since compiling
        if has_external_data(model):
            return str(path)
        checked.remember(data)
        return data

    def setup(self, start: float, stop: float) -> None:
        """Allocate input buffers from start values, run once so outputs hold initial values."""
        strings = [p.name for p in self.component.interface.ports if p.dtype is DType.STRING]
        if strings:  # readable (validate, inspect), but no buffer of numbers can carry them
            raise fault(
                self.component.name,
                f"string tensors ({', '.join(strings)}) cannot be run: fmionnx passes numbers "
                "between components",
                time=start,
            )
        explicit = {p.port: p.value for p in self.component.parameters}
        dims = bind_dims(self.component.interface.ports, self._sizes)
        for port in self.component.interface.with_causality(Causality.INPUT):
            shape = concrete_shape(port, self._sizes.get(port.name), dims)
            buffer = np.zeros(math.prod(shape), dtype=port.dtype.value)
            value = explicit.get(port.name, port.start)
            if value is not None:
                buffer[:] = np.asarray(value, dtype=buffer.dtype).reshape(-1)[: buffer.size]
            self._inputs[port.name] = buffer
            self._feeds[port.name] = buffer.reshape(shape)
        declared = {p.name: p for p in self.component.interface.with_causality(Causality.OUTPUT)}
        self._names = list(declared)
        results = self._run(start)
        for name, value in zip(self._names, results, strict=True):
            array = np.asarray(value)
            self._check_output(declared[name], array, dims, start)
            self._outputs[name] = np.array(array.reshape(-1), copy=True)

    def _check_output(self, port: Port, array: Any, dims: Dims, start: float) -> None:
        """Fault unless the first value of output ``port`` has the size its declared shape
        has once the inputs fixed its names: the run's columns and connections are sized
        from that shape, so an output of another size (an Expand to a shape it computes) is a
        fault here, not a crash where the value is first recorded. A dimension no input fixes
        (an unnamed one, a name only outputs use) takes what the model gives."""
        resolved = resolved_shape(port, dims)
        count = known_count(resolved)
        known = math.prod(d for d in resolved if d is not None)
        if count is not None:
            fits = array.size == count
        else:  # a zero dimension beside the open ones: the output is empty
            fits = array.size % known == 0 if known else array.size == 0
        if not fits:
            named = {d: dims.bound[d] for d in port.shape if isinstance(d, str) and d in dims.bound}
            fixed = f" with {', '.join(f'{k} = {v}' for k, v in named.items())}" if named else ""
            raise fault(
                self.component.name,
                f"output has shape {list(array.shape)}, not the shape the model declares "
                f"for it ({list(port.shape)}{fixed})",
                time=start,
                port=port.name,
            )

    def input_buffer(self, port: str) -> Buffer:
        """Flat buffer behind the tensor fed to input ``port``."""
        return self._inputs[port]

    def output_buffer(self, port: str) -> Buffer:
        """Flat copy of the newest value of output ``port``."""
        return self._outputs[port]

    def interrupt(self, reason: str) -> None:
        """Stop the run under way from another thread (the step-timeout watchdog): it raises
        a fault saying ``reason``. onnxruntime looks at the flag before each node and each
        iteration of a ``Loop``, so a model that never ends is stopped; one kernel that runs
        for ever is not (the watchdog then abandons the run)."""
        self._stopped = reason
        if self._run_options is not None:
            self._run_options.terminate = True

    def _session_key(self, config: OnnxConfig, threads: int | None) -> tuple[object, ...] | None:
        """What a kept session must have been made from to serve this run (None: never one)."""
        if not SESSIONS.enabled:
            return None
        path = self.component.path
        try:
            info = path.stat()
        except OSError:
            return None
        identity = (str(path.resolve()), info.st_mtime_ns, info.st_size)
        return (*identity, self.component.interface.content_hash, config.providers, threads)

    def _run(self, t: float) -> list[Any]:
        try:
            results: list[Any] = self._session.run(self._names, self._feeds, self._run_options)
        except Exception as exc:
            self._broken = True
            if self._stopped is not None:
                raise fault(self.component.name, self._stopped, time=t) from None
            over = _over_the_ceiling(str(exc))
            if over is not None:
                raise fault(self.component.name, over, time=t) from None
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise fault(self.component.name, f"onnxruntime failed: {text}", time=t) from None
        return results

    def evaluate_at_start(self, start: float) -> None:
        """Outputs at the start time from the connected inputs' start values (StartEvaluating).

        :meth:`setup` ran the model on the inputs' own start values (often zeros) only to size
        the outputs; the backend calls this once the connections have written their values.
        """
        self._compute(start)

    def step(self, t: float, h: float) -> None:
        """Run the model on the current inputs; outputs belong to time ``t + h``."""
        self._compute(t)

    def _compute(self, t: float) -> None:
        """Run the model on the current inputs and copy the results into the output buffers."""
        results = self._run(t)
        outputs = self._outputs
        for name, value in zip(self._names, results, strict=True):
            target = outputs[name]
            if value.size != target.size:
                raise fault(
                    self.component.name,
                    f"output has {value.size} elements, expected {target.size}",
                    time=t,
                    port=name,
                )
            np.copyto(target, value.reshape(-1), casting="unsafe")

    def save_state(self, t: float) -> None:
        """An ONNX model has no state: keep its outputs only (iterated algebraic loops)."""
        if self._saved is None:
            self._saved = OutputCopies(list(self._outputs.values()))
        self._saved.save()

    def restore_state(self, t: float) -> None:
        """Back to the outputs of :meth:`save_state`; the next step recomputes them anyway."""
        if self._saved is not None:
            self._saved.restore()

    def produce(self, port: str) -> None:
        """ONNX outputs are refreshed every step; nothing is lazy."""

    def terminate(self) -> None:
        """Drop the session, or give it back for the next run of the model (a study's
        worker; only when no inference failed)."""
        session, self._session = self._session, None
        if session is not None and self._key is not None and not self._broken:
            SESSIONS.give(self._key, session)
