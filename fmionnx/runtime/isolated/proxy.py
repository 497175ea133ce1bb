"""The supervisor's side: a runner whose model lives in a child process.

:class:`IsolatedRunner` implements the runner contract (:mod:`fmionnx.core.runner`), so the
master cannot tell it from the runner it stands for: its port buffers are views of the memory
block it shares with the child, and a step is one byte down a pipe and one byte back. What a
model does to its own process becomes a :class:`RunError` naming the component, the FMI
function (the phase the child was in) and the simulated time:

- the process dies (segfault, ``abort()``, ``exit()``): the pipe closes, the exit status says
  how;
- a call does not return within the step timeout: the process is killed.

The run then ends as a fault like any other, so the master writes everything recorded up to
the last completed step, and the child's temporary folder is removed whatever happened.
"""

from __future__ import annotations

import atexit
import contextlib
import fcntl
import mmap
import os
import signal
import subprocess
import tempfile
import threading
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np

from fmionnx.core.errors import RunError
from fmionnx.core.processlocal import ProcessLocal
from fmionnx.core.runner import Buffer, Wiring, fault
from fmionnx.core.scratch import make_scratch, remove_scratch
from fmionnx.core.types import Component
from fmionnx.runtime.isolated import channel, handover, launcher
from fmionnx.runtime.isolated.channel import Control
from fmionnx.runtime.isolated.launcher import ChildProcess
from fmionnx.runtime.isolated.limits import memory_note
from fmionnx.runtime.native import kernel as k
from fmionnx.runtime.parallel import on_lane
from fmionnx.runtime.stopping import shield_begin, shield_end

#: Seconds a child gets to terminate its model and exit before it is killed.
TERMINATE_GRACE = 5.0
#: Seconds added to the step timeout for the first answer: it includes starting the child's
#: Python interpreter, which is not the model's time and takes seconds on a loaded machine.
PROCESS_START_ALLOWANCE = 10.0
#: How long the supervisor spins on the child's reply counter before it blocks on the pipe
#: (see :class:`~.channel.Spinner`; the figures behind the choice: docs/performance.md). A
#: supervisor confined to one core does not spin (:func:`supervisor_spin_ns`).
SPIN_NS = 60_000


def supervisor_spin_ns() -> int:
    """:data:`SPIN_NS`, or 0 in a process confined to one core (a study's pinned worker,
    ``taskset -c 0``): its children run on that core too, and only once it waits."""
    from fmionnx.core.cores import usable_cores

    return SPIN_NS if usable_cores() > 1 else 0


#: Whether children started from now on in this process spin before they block (see
#: :func:`one_core_each`).
_children_spin = [True]


def children_spin() -> bool:
    """Whether an isolated child spins on its command counter before it blocks: not once
    cases have one core each (:func:`one_core_each`), nor in a process confined to one core
    (the child would spin on the core its supervisor needs to send the next command)."""
    from fmionnx.core.cores import usable_cores

    return _children_spin[0] and usable_cores() > 1


def one_core_each() -> None:
    """From now on, this process's isolated children block on their pipe at once.

    A child's spin (``server.SPIN_NS``) buys latency with a second core; where every core
    already runs a case of a sweep, that core belongs to another case (see docs/sweep.md).
    """
    _children_spin[0] = False


#: Idle children one process keeps for the next runs of their models (the least recently
#: used one is ended first).
MAX_IDLE_CHILDREN = 8


@dataclass
class _IdleChild:
    """A child whose run ended cleanly, kept with its pipes, shared memory and scratch folder
    for the next run of the same model; ``sent``/``answered`` continue the control block's
    counters."""

    key: tuple[str, str, str]
    process: ChildProcess
    commands: int
    replies: int
    shared: int
    tmp: Path | None
    sent: int
    answered: int

    def close(self) -> None:
        """End it: its command pipe closes, so it leaves its loop and exits (killed if not)."""
        with contextlib.suppress(OSError):
            os.close(self.commands)
        try:
            self.process.wait(TERMINATE_GRACE)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        for handle in (self.replies, self.shared):
            with contextlib.suppress(OSError):
                os.close(handle)
        if self.tmp is not None:
            remove_scratch(self.tmp)


class _ChildPool:
    """Idle children by model; thread-safe (cases of a multi-threaded worker share it)."""

    def __init__(self) -> None:
        self._idle: list[_IdleChild] = []
        self._lock = threading.Lock()

    def take(self, key: tuple[str, str, str]) -> _IdleChild | None:
        with self._lock:
            for index in range(len(self._idle) - 1, -1, -1):
                if self._idle[index].key == key:
                    return self._idle.pop(index)
        return None

    def put(self, child: _IdleChild) -> None:
        with self._lock:
            self._idle.append(child)
            surplus = self._idle[:-MAX_IDLE_CHILDREN] if len(self._idle) > MAX_IDLE_CHILDREN else []
            del self._idle[: len(surplus)]
        for old in surplus:
            old.close()

    def close(self) -> None:
        with self._lock:
            idle, self._idle = self._idle, []
        for child in idle:
            child.close()


#: This process's idle children, once :func:`keep_children` was called here (a forked process
#: -- the guardian's child -- does not use its parent's).
_children: ProcessLocal[_ChildPool] = ProcessLocal()


def keep_children() -> None:
    """From now on, an isolated child whose run ended cleanly serves the next run of the same
    model in this process (a study's worker: its cases run one model after the other).

    The child ends its model (``terminate``, the instance freed) and waits; the next run makes
    a new instance in it, on the library it kept loaded (the kind's worker settings, see
    :mod:`fmionnx.kinds.fmu.libraries`), instead of a new process, unpacking and loading. A
    run that faulted, crashed, hung or was stopped never gives its child back, so a case that
    breaks its model's process breaks no other case; a model whose kind says it may be
    instantiated only once per process (:class:`~fmionnx.kinds.base.SharedProcess`) gets a
    fresh process every run; a sandboxed one too (its confinement is per run).
    """
    _children.get_or_make(_ChildPool)


@atexit.register
def _close_children() -> None:
    pool = _children.clear()
    if pool is not None:
        pool.close()


@dataclass(frozen=True)
class IsolationSettings:
    """How isolated components run: a step timeout (None: wait for ever) and confinement."""

    step_timeout: float | None = None
    sandbox: bool = False


def _memory_file(name: str) -> int:
    """An anonymous shared file of :data:`~.channel.CONTROL_SIZE` bytes that cannot shrink.

    Nothing on disk to leak, whatever way the run ends. The child may grow it (it sizes the
    data block) but never shrink it: memory the supervisor has mapped always stays backed, so
    a hostile model cannot make the supervisor fault by truncating the file.
    """
    if hasattr(os, "memfd_create"):
        handle = os.memfd_create(f"fmionnx-{name}", os.MFD_ALLOW_SEALING)
        os.ftruncate(handle, channel.CONTROL_SIZE)
        fcntl.fcntl(handle, fcntl.F_ADD_SEALS, fcntl.F_SEAL_SHRINK)
        return handle
    handle, path = tempfile.mkstemp(prefix="fmionnx-shm-")
    Path(path).unlink()
    os.ftruncate(handle, channel.CONTROL_SIZE)
    return handle


class IsolatedRunner:
    """Runs one component's ordinary runner in a child process (``--isolate``)."""

    def __init__(self, component: Component, wiring: Wiring, settings: IsolationSettings) -> None:
        self.component = component
        self.lazy_outputs: frozenset[str] = frozenset()
        self._wiring = wiring
        self._settings = settings
        self._process: ChildProcess | None = None
        self._commands = self._replies = self._shared = -1
        self._control: Control | None = None
        self._block: mmap.mmap | None = None
        self._data: mmap.mmap | None = None
        self._buffers: dict[tuple[str, bool], Buffer] = {}
        self._labels: tuple[str, ...] = channel.FIXED_PHASES
        self._times = np.zeros(2)
        #: Replies still to read, oldest first: True for a request (its reply has a payload).
        self._pending: deque[bool] = deque()
        #: Commands written and replies read so far (the control block's counters' partners).
        self._sent = self._answered = 0
        self._spinner = channel.Spinner(supervisor_spin_ns())
        #: The kernel's end of the step hand-over, once set up (:mod:`.handover`).
        self._link: handover.Link | None = None
        #: Whether the native kernel steps the model in its child (reported at setup).
        self.stepped_natively = False
        #: The first byte of the oldest pending reply, when the kernel read it already.
        self._tag: bytes | None = None
        self._tmp: Path | None = None
        self._time = 0.0
        self._dead = False
        #: The model answered a call with an error in this run: its process is not kept.
        self._faulted = False

    # -- life cycle ----------------------------------------------------------------------------

    def _reuse_key(self) -> tuple[str, str, str] | None:
        """What a kept child must have run to serve this runner (None: never a kept one)."""
        from fmionnx.kinds.registry import process_reusable

        component = self.component
        if self._settings.sandbox or _children.get() is None:
            return None
        if not process_reusable(component):
            return None
        return (component.kind, component.interface.content_hash, str(component.path))

    def instantiate(self) -> None:
        """Start the child (or take one kept for this model) and ask it to load the model; the
        answer is awaited in setup.

        Not waiting here lets every isolated component start its process at the same time.
        """
        key = self._reuse_key()
        pool = _children.get()
        kept = pool.take(key) if pool is not None and key is not None else None
        while kept is not None and kept.process.poll() is not None:  # died while idle
            kept.close()
            kept = pool.take(key) if pool is not None and key is not None else None
        if kept is not None:
            self._adopt(kept)
        else:
            self._launch(keep=key is not None)
        self._request("instantiate", self.component, self._wiring)

    def _adopt(self, kept: _IdleChild) -> None:
        """Serve this run with a child kept from an earlier run of the same model."""
        self._process = kept.process
        self._commands, self._replies, self._shared = kept.commands, kept.replies, kept.shared
        self._tmp = kept.tmp
        self._sent, self._answered = kept.sent, kept.answered
        self._block = mmap.mmap(self._shared, channel.CONTROL_SIZE)
        self._control = Control(self._block)
        self._times = self._control.times

    def _launch(self, *, keep: bool) -> None:
        """Start a new child for this run (``keep``: one that may serve the next runs)."""
        name = self.component.name
        command_read, command_write = os.pipe()
        reply_read, reply_write = os.pipe()
        self._shared = _memory_file(name)
        self._tmp = make_scratch(f"isolated-{name}")
        env = dict(os.environ, TMPDIR=str(self._tmp))
        argv = [] if children_spin() else ["--no-spin"]
        if keep:
            argv.append("--keep")
        if self._settings.sandbox:
            from fmionnx.kinds.registry import confined_environment

            env.update(confined_environment(self.component))
            argv += ["--sandbox", str(self._tmp), str(self.component.path)]
        try:
            self._process = launcher.launch((command_read, reply_write, self._shared), argv, env)
        except OSError as exc:  # no process to be had (limits, memory): a fault, not a crash
            self._dead = True
            raise fault(name, f"could not start its isolated process: {exc}", time=0.0) from None
        finally:
            os.close(command_read)
            os.close(reply_write)
        self._commands, self._replies = command_write, reply_read
        self._block = mmap.mmap(self._shared, channel.CONTROL_SIZE)
        self._control = Control(self._block)
        self._times = self._control.times

    def setup(self, start: float, stop: float) -> None:
        """Wait for the model to load, then initialize it and map the port buffers it reports."""
        self._time = start
        limit = self._settings.step_timeout
        self._await(self._time, 0.0, None if limit is None else limit + PROCESS_START_ALLOWANCE)
        self._request("setup", start, stop)
        document = self._await_answer()
        available = os.fstat(self._shared).st_size - channel.CONTROL_SIZE
        ports = frozenset(p.name for p in self.component.interface.ports)
        try:
            layout = channel.parse_layout(document, ports, available)
        except channel.MalformedReplyError as exc:
            self._malformed(str(exc))
        self._data = mmap.mmap(self._shared, max(layout.size, 8), offset=channel.CONTROL_SIZE)
        for slot in layout.slots:
            self._buffers[(slot.port, slot.is_input)] = channel.view(self._data, slot)
        self.lazy_outputs = layout.lazy_outputs
        self._labels = channel.FIXED_PHASES + layout.step_labels
        self.stepped_natively = layout.native
        kernel = handover.native_kernel()
        if kernel is not None and self._control is not None:
            self._link = handover.Link(
                kernel, self._commands, self._replies, self._control,
                self._settings.step_timeout, self._spinner.budget_ns,
            )  # fmt: skip

    def input_buffer(self, port: str) -> Buffer:
        """The shared slot the child copies into the model's input before each step."""
        try:
            return self._buffers[(port, True)]
        except KeyError:
            msg = f"{self.component.name}.{port} is not a runtime input of this component"
            raise KeyError(msg) from None

    def output_buffer(self, port: str) -> Buffer:
        """The shared slot the child refreshes after each step."""
        try:
            return self._buffers[(port, False)]
        except KeyError:
            msg = f"{self.component.name}.{port} is not a numeric output of this component"
            raise KeyError(msg) from None

    def step(self, t: float, h: float) -> None:
        """One step in the child: times into shared memory, one byte there and back."""
        self._time = t
        times = self._times
        times[0] = t
        times[1] = h
        link = self._link
        if link is not None and not self._pending:
            self._step_through(link, t, h)
            return
        self._pending.append(False)
        try:
            channel.write_all(self._commands, channel.STEP)
        except BrokenPipeError:  # the child is gone (killed from outside between two steps)
            self._died(t, h)
        self._sent_one()
        control = self._control
        if control is not None and not on_lane():
            # A hint only: _await polls and reads as without it. Not on a lane: a spin holds
            # the GIL, which a lane's wait must leave to the loop's thread.
            self._spinner.wait(control.replies, self._answered & channel.COUNTER_MASK)
        self._await(t, h)

    def _step_through(self, link: handover.Link, t: float, h: float) -> None:
        """The step's round trip made by the kernel (:mod:`.handover`).

        Whatever interrupts the call, the counters and the pending reply are brought up to
        what the kernel did, inside a shield: a stop request is raised once they say what the
        child was sent and what of its answer was read, so that ending the model reads
        exactly the rest. A signal that interrupts the write leaves the command unwritten:
        it is written again, as Python's own write does, unless the signal stopped the run.
        """
        while True:
            sent, answered = self._sent, self._answered
            link.prepare(sent, answered)
            code = k.LINK_INTERRUPTED
            shield_begin()
            try:
                try:
                    code = link.call(spin=not on_lane())
                finally:
                    self._settle(link, sent, answered)
            finally:
                shield_end()
            if self._pending:  # sent, not answered (or an answer that is not OK, read on)
                self._step_went_wrong(link, code, t, h)
                return
            if code == k.LINK_REPLY:
                return
            if code == k.LINK_BROKEN:
                self._died(t, h)
            if code == k.LINK_ERRNO:
                raise OSError(link.error, os.strerror(link.error))

    def _settle(self, link: handover.Link, sent: int, answered: int) -> None:
        """The counters and pending replies after the kernel's call (see :meth:`_step_through`):
        a reply's first byte that is not OK is kept for :meth:`_await`, which reads the rest.
        The pending reply is recorded last, once everything it depends on is."""
        written, replied, tag = link.written(sent), link.answered(answered), link.tag
        if not written:
            return
        self._sent = sent + 1
        if replied and tag == channel.OK:
            self._answered = answered + 1
            return
        if replied:
            self._tag = tag
        self._pending.append(False)

    def _step_went_wrong(self, link: handover.Link, code: int, t: float, h: float) -> None:
        """The kernel's hand-over sent the step but did not end in an OK: go on exactly as
        the Python one does at that point (the timeout, the child gone, an error reply, a
        signal or a long step: the wait goes on in Python)."""
        if code == k.LINK_TIMEOUT:
            self._kill_hung(t, h, self._settings.step_timeout or 0.0)
        elif code == k.LINK_CLOSED:
            self._died(t, h)
        elif code == k.LINK_ERRNO:
            raise OSError(link.error, os.strerror(link.error))
        self._await(t, h)

    @property
    def waits_spun(self) -> int:
        """How many of this runner's waits for a step's reply spun before they blocked."""
        return self._spinner.spins + (self._link.spins if self._link is not None else 0)

    def produce(self, port: str) -> None:
        """Refresh a lazy output in the child."""
        self._request("produce", port)
        self._await_answer()

    def save_state(self, t: float) -> None:
        """Keep the model's state in the child (an iterated algebraic loop repeats a step)."""
        self._request("save_state", t)
        self._await_answer()

    def restore_state(self, t: float) -> None:
        """Go back to the saved state; the child republishes the outputs it had then."""
        self._request("restore_state", t)
        self._await_answer()

    def terminate(self) -> None:
        """Terminate the model, end the child (killing it if it does not end), clean up; or,
        where this process keeps children (:func:`keep_children`) and the run ended cleanly,
        keep the child for the next run of the model."""
        process = self._process
        if process is None:
            self._cleanup()
            return
        if self._give_back(process):
            return
        self._process = None
        try:
            if not self._dead and process.poll() is None:
                if channel.writable(self._commands, TERMINATE_GRACE):
                    with contextlib.suppress(OSError, RunError):
                        self._request("terminate")
                        while self._pending:  # a step interrupted by Ctrl-C answers first
                            self._await(self._time, 0.0, timeout=TERMINATE_GRACE)
                    if self._dead:  # no answer within the grace: hung, so no second wait
                        process.kill()
                else:  # it stopped reading its commands (a hostile model can): nothing to ask
                    process.kill()
            process.wait(TERMINATE_GRACE)
        except subprocess.TimeoutExpired:
            pass
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
            self._cleanup()

    def _give_back(self, process: ChildProcess) -> bool:
        """End the model but keep its child for the next run (True), when this process keeps
        children and nothing went wrong: no fault, nothing pending, the model ended cleanly."""
        key = self._reuse_key()
        pool = _children.get()
        broken = self._dead or self._faulted or bool(self._pending)
        if key is None or pool is None or broken or process.poll() is not None:
            return False
        try:
            self._request("release")
            self._await(self._time, 0.0, timeout=TERMINATE_GRACE)
        except (OSError, RunError):
            return False  # ended as a child is ended otherwise: terminated, or killed
        kept = _IdleChild(
            key, process, self._commands, self._replies, self._shared, self._tmp,
            self._sent, self._answered,
        )  # fmt: skip
        self._process = None
        self._commands = self._replies = self._shared = -1
        self._tmp = None
        self._cleanup()
        pool.put(kept)
        return True

    # -- talking to the child ------------------------------------------------------------------

    def _request(self, name: str, *args: object) -> None:
        self._pending.append(True)
        try:
            channel.send(self._commands, channel.CALL, (name, args))
        except BrokenPipeError:
            self._died(self._time, 0.0)
        self._sent_one()

    def _sent_one(self) -> None:
        """A whole command is in the pipe: say so in the counter the child may spin on."""
        self._sent += 1
        if self._control is not None:
            self._control.requests.value = self._sent & channel.COUNTER_MASK

    def _await_answer(self) -> object:
        return self._await(self._time, 0.0)

    def _await(self, t: float, h: float, timeout: float | None = None) -> object:
        """The child's reply to the oldest pending command; faults become RunErrors."""
        tag, self._tag = self._tag, None
        if tag is None:
            limit = self._settings.step_timeout if timeout is None else timeout
            if limit is not None and not channel.readable(self._replies, limit):
                self._kill_hung(t, h, limit)
            tag = channel.read_exact(self._replies, 1)
            if tag is None:
                self._died(t, h)
        return self._reply(tag)

    def _reply(self, tag: bytes) -> object:
        """The rest of the reply to the oldest pending command, whose first byte was ``tag``."""
        self._answered += 1
        is_request = self._pending.popleft()
        if tag not in (channel.OK, channel.ERROR):
            self._malformed(f"an unknown reply {tag!r}")
        try:
            if tag == channel.OK:
                return channel.receive_reply(self._replies) if is_request else None
            parsed = channel.parse_error(channel.receive_reply(self._replies))
        except channel.MalformedReplyError as exc:
            self._malformed(str(exc))
        self._faulted = True
        raise channel.error_from(parsed, self.component.name)

    def _malformed(self, problem: str) -> NoReturn:
        """The child broke the protocol (a hostile or corrupted model): stop it, fault."""
        self._dead = True
        if self._process is not None:
            self._process.kill()
            self._process.wait()
        raise fault(
            self.component.name,
            f"its process sent {problem} in {self._phase_label()}; the process was stopped",
            time=self._time,
        )

    def _phase(self) -> int:
        return self._control.phase.value if self._control is not None else 0

    def _phase_label(self) -> str:
        index = self._phase()
        return self._labels[index] if 0 <= index < len(self._labels) else f"phase {index}"

    def _time_of_phase(self, t: float, h: float) -> float:
        """Outputs are got at the end of the step; everything else happens at its start."""
        last = len(self._labels) - 1
        return t + h if self._phase() == last and last >= channel.FIRST_STEP_PHASE else t

    def _died(self, t: float, h: float) -> NoReturn:
        """The child is gone: say how, in which phase, at which time."""
        self._dead = True
        process = self._process
        code = process.wait() if process is not None else None
        if code is not None and code < 0:
            try:
                how = f"crashed with {signal.Signals(-code).name}"
            except ValueError:
                how = f"was killed by signal {-code}"
        elif code is not None:
            how = f"ended its process with exit status {code}"
        else:
            how = "ended its process"
        raise fault(
            self.component.name,
            f"the model {how} in {self._phase_label()} (it ran isolated in its own process"
            f"{memory_note()})",
            time=self._time_of_phase(t, h),
        )

    def _kill_hung(self, t: float, h: float, limit: float) -> NoReturn:
        self._dead = True
        label = self._phase_label()
        if self._process is not None:
            self._process.kill()
            self._process.wait()
        raise fault(
            self.component.name,
            f"{label} did not return within {limit:g} s (the step timeout); its process was killed",
            time=self._time_of_phase(t, h),
        )

    def _cleanup(self) -> None:
        self._link = None
        self._buffers.clear()
        self._times = np.zeros(2)
        self._control = None
        for handle in (self._commands, self._replies, self._shared):
            if handle >= 0:
                with contextlib.suppress(OSError):
                    os.close(handle)
        self._commands = self._replies = self._shared = -1
        for block in (self._data, self._block):
            if block is not None:
                with contextlib.suppress(BufferError):
                    block.close()
        if self._tmp is not None:
            remove_scratch(self._tmp)
            self._tmp = None
