"""The request loop of an isolated component's child process (see :mod:`.child`)."""

from __future__ import annotations

import contextlib
import mmap
import os
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from fmionnx.core.errors import ModelTerminated, RunError
from fmionnx.core.runner import Buffer, Runner, StateSaving
from fmionnx.core.types import Causality
from fmionnx.runtime.isolated import channel, handover
from fmionnx.runtime.isolated.channel import Control, Layout, Slot
from fmionnx.runtime.isolated.limits import memory_note
from fmionnx.runtime.native import kernel as k

Phase = tuple[str, Callable[[float, float], None]]

#: How long the child spins on the supervisor's command counter before it blocks on the pipe
#: (see :class:`~.channel.Spinner`; the figures behind the choice: docs/performance.md). The
#: child spins *politely* (yielding its core at every turn): between two of its steps the
#: master may be stepping other isolated models, whose processes need the cores more.
SPIN_NS = 300_000


class Child:
    """One runner behind the pipes; the buffers it copies between the runner and shared memory."""

    def __init__(
        self, commands: int, replies: int, shared: int, refusal: str | None, *, spin: bool = True
    ) -> None:
        self.commands, self.replies, self.shared = commands, replies, shared
        #: Why the model must not be loaded (the sandbox asked for could not be set up).
        self.refusal = refusal
        self.block = mmap.mmap(shared, channel.CONTROL_SIZE)
        self.control = Control(self.block)
        self.runner: Runner | None = None
        self.data: mmap.mmap | None = None
        self.inputs: list[tuple[Buffer, Buffer]] = []
        self.outputs: list[tuple[Buffer, Buffer]] = []
        self.produced: dict[str, tuple[Buffer, Buffer]] = {}
        self.phases: tuple[Phase, ...] = ()
        #: Commands read and replies written so far (the control block's counters' partners).
        self.consumed = self.written = 0
        self.spin_ns = SPIN_NS if spin else 0
        self.spinner = channel.Spinner(self.spin_ns, polite=True)
        #: The kernel's end of the step hand-over, when it can step the runner (:mod:`.handover`).
        self.native: handover.Server | None = None

    # -- the loop ------------------------------------------------------------------------------

    def serve(self) -> None:
        """Answer commands until terminate, or until the command pipe closes."""
        control = self.control
        while True:
            if self.native is not None:  # steps in the kernel until anything else comes
                op = self._serve_natively(self.native)
                if op is None:
                    return
                if op == channel.STEP:  # a fault of the kernel's step: answered, go on
                    continue
            else:
                self.spinner.wait(control.requests, self.consumed & channel.COUNTER_MASK)
                op = channel.read_exact(self.commands, 1)
                if op is None:
                    return
                self.consumed += 1
            try:
                if op == channel.STEP:
                    self.step()
                    channel.write_all(self.replies, channel.OK)
                    self._replied()
                    continue
                request = channel.receive_payload(self.commands)
                if request is None:
                    return
                name, args = cast(tuple[str, tuple[Any, ...]], request)
                answer = getattr(self, f"do_{name}")(*args)
                if isinstance(answer, Layout):
                    answer = channel.layout_document(answer)
                channel.reply(self.replies, channel.OK, answer)
                self._replied()
                if name == "terminate":
                    return
            except Exception as exc:
                self._reply_error(exc)

    def _reply_error(self, exc: Exception) -> None:
        """Answer the command under way with what it raised."""
        if isinstance(exc, RunError):
            channel.reply(self.replies, channel.ERROR, channel.error_document(exc))
        else:
            detail = f"{type(exc).__name__}: {exc}"
            if isinstance(exc, MemoryError):  # perhaps the process's memory limit
                detail += memory_note()
            channel.reply(self.replies, channel.ERROR, [detail, None, None])
        self._replied()

    def _serve_natively(self, native: handover.Server) -> bytes | None:
        """Let the kernel serve steps; the command it did not serve (STEP: a step of its that
        failed, answered here), or None when the command pipe closed."""
        while True:
            code, read, written = native.serve(self.consumed, self.written)
            self.consumed += read
            self.written += written
            if code == k.SERVE_COMMAND:
                return native.op
            if code == k.SERVE_FAULT:
                self._native_fault(native)
                return channel.STEP
            if code == k.LINK_CLOSED:
                return None
            if code == k.LINK_ERRNO:
                raise OSError(native.error, os.strerror(native.error))
            # LINK_INTERRUPTED: back in Python, where a signal's handler runs; serve on

    def _native_fault(self, native: handover.Server) -> None:
        """The kernel's step failed: the fault the Python path raises, answered as it is."""
        t, h = float(self.control.times[0]), float(self.control.times[1])
        phase = self.control.phase

        def getting() -> None:  # a model ending the run: its outputs are got, as in Python
            phase.value = channel.FIRST_STEP_PHASE + 2

        try:
            error: Exception = native.group.fault(native.code, t, h, getting)
        except Exception as exc:  # naming it failed: answered as a step's exception is
            error = exc
        if isinstance(error, ModelTerminated):
            self._publish()  # the step completed: the master records its outputs
        self._reply_error(error)

    def _replied(self) -> None:
        """A whole reply is in the pipe: say so in the counter the supervisor may spin on."""
        self.written += 1
        self.control.replies.value = self.written & channel.COUNTER_MASK

    def step(self) -> None:
        t, h = float(self.control.times[0]), float(self.control.times[1])
        for shared, own in self.inputs:
            own[...] = shared
        phase = self.control.phase
        try:
            for index, (_, part) in enumerate(self.phases, channel.FIRST_STEP_PHASE):
                phase.value = index
                part(t, h)
        except ModelTerminated:
            self._publish()  # the step completed: the master records its outputs
            raise
        self._publish()

    def _publish(self) -> None:
        for shared, own in self.outputs:
            shared[...] = own

    # -- requests ------------------------------------------------------------------------------

    def do_instantiate(self, component: Any, wiring: Any) -> None:
        from fmionnx.kinds.registry import make_runner

        self.control.phase.value = channel.PHASE_INSTANTIATE
        if self.refusal is not None:
            raise RunError(f"component `{component.name}`: --sandbox: {self.refusal}")
        self.runner = make_runner(component, wiring)
        self.runner.instantiate()

    def do_setup(self, start: float, stop: float) -> Layout:
        runner = self._runner()
        self.control.phase.value = channel.PHASE_SETUP
        runner.setup(start, stop)
        owned = self._buffers(runner)
        size = 0
        slots = []
        for port, is_input, buffer in owned:
            slots.append(Slot(port, is_input, buffer.dtype.str, size, buffer.size))
            size += -(-buffer.nbytes // 8) * 8  # 8-byte aligned
        os.ftruncate(self.shared, channel.CONTROL_SIZE + max(size, 8))
        if self.data is not None:  # a process serving another run of its model
            with contextlib.suppress(BufferError):
                self.data.close()
        self.data = mmap.mmap(self.shared, max(size, 8), offset=channel.CONTROL_SIZE)
        for slot, (_, _, own) in zip(slots, owned, strict=True):
            shared = channel.view(self.data, slot)
            shared[...] = own  # start values: unconnected inputs keep them
            if slot.port in runner.lazy_outputs:
                self.produced[slot.port] = (shared, own)
            else:
                (self.inputs if slot.is_input else self.outputs).append((shared, own))
        phases = getattr(runner, "step_phases", None)
        self.phases = phases() if phases is not None else (("the step", runner.step),)
        self.native = handover.serving(
            runner, self.control, (self.commands, self.replies), (self.inputs, self.outputs),
            len(self.phases), self.spin_ns,
        )  # fmt: skip
        labels = tuple(label for label, _ in self.phases)
        return Layout(tuple(slots), size, runner.lazy_outputs, labels, self.native is not None)

    def do_produce(self, port: str) -> None:
        runner = self._runner()
        self.control.phase.value = channel.PHASE_PRODUCE
        runner.produce(port)
        shared, own = self.produced[port]
        shared[...] = own

    def do_save_state(self, t: float) -> None:
        self._saving().save_state(t)

    def do_restore_state(self, t: float) -> None:
        """Restore the model, then publish its restored outputs in the shared block."""
        self._saving().restore_state(t)
        for shared, own in (*self.outputs, *self.produced.values()):
            shared[...] = own

    def _saving(self) -> StateSaving:
        runner = self._runner()
        if not isinstance(runner, StateSaving):
            msg = f"the runner of `{runner.component.name}` cannot save and restore its state"
            raise TypeError(msg)
        return runner

    def do_terminate(self) -> None:
        self.control.phase.value = channel.PHASE_TERMINATE
        if self.runner is not None:
            self.runner.terminate()

    def do_release(self) -> None:
        """End this run's model and wait for the next run's ``instantiate`` (a process kept
        for the next runs of its model: :func:`~.proxy.keep_children`)."""
        self.control.phase.value = channel.PHASE_TERMINATE
        runner, self.runner = self.runner, None
        self.native = None
        try:
            if runner is not None:
                runner.terminate()
        finally:
            self.inputs.clear()
            self.outputs.clear()
            self.produced.clear()
            self.phases = ()
            data, self.data = self.data, None
            if data is not None:
                with contextlib.suppress(BufferError):
                    data.close()

    # -- helpers -------------------------------------------------------------------------------

    def _runner(self) -> Runner:
        if self.runner is None:
            msg = "the isolated runner was used before it was instantiated"
            raise RuntimeError(msg)
        return self.runner

    @staticmethod
    def _buffers(runner: Runner) -> list[tuple[str, bool, Buffer]]:
        """Every port buffer the runner has: inputs (and driven parameters), then outputs."""
        found: list[tuple[str, bool, Buffer]] = []
        for port in runner.component.interface.ports:
            is_input = port.causality is not Causality.OUTPUT
            try:
                buffer = (
                    runner.input_buffer(port.name) if is_input else runner.output_buffer(port.name)
                )
            except KeyError:
                continue
            found.append((port.name, is_input, np.asarray(buffer).reshape(-1)))
        return found
