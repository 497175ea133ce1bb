"""One step of one unit of work: what every stepping loop of fmionnx does, defined once.

A :class:`Work` is a component (or a native group, or an iterated algebraic loop) with what
its step needs, prepared before a run: the transfers that feed its inputs, its step function,
its step length and the tracks that record its inputs (sampled before the step) and outputs
(after). Its phases, in this order, are the semantics of a communication point
(docs/running.md):

1. :meth:`Work.feed` — each connection copies the producer's newest output into an input;
2. :meth:`Work.record_inputs` — the inputs as the step uses them;
3. :meth:`Work.advance` — the step from ``t`` by ``h``;
4. :meth:`Work.record_outputs` — the outputs the step produced.

:meth:`Work.perform` runs them in order. The sequential master performs each due work; the
parallel master feeds and records inputs on its own thread and hands :meth:`Work.advance` to a
lane, recording outputs when it joins; the loop solver feeds and advances its members once per
sweep and records the kept sweep; a ROS 2 node performs its one component's work after its
inputs arrived. A model that ends the run during its step (``ModelTerminated``) has completed
that step: its outputs are recorded before the request goes on up.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from fmionnx.core.errors import ModelTerminated
from fmionnx.runtime.recorder import Track
from fmionnx.runtime.transfer import Transfer

#: ``step(t, h)``: a runner's step, a native group's, or an iterated loop's.
StepFunction = Callable[[float, float], None]


class Marks(Protocol):
    """Where a loop marks the work whose step is under way (the watchdog's and the guardian's
    marker: :class:`fmionnx.runtime.watchdog.Marker`)."""

    work: object


@dataclass(slots=True)
class Work:
    """One unit of work at a communication point where it is due (module docstring)."""

    name: str
    transfers: tuple[Transfer, ...]
    step: StepFunction
    h: float
    before: Track | None
    after: Track | None
    #: The components this work steps: one, a native group's members or a loop's members.
    members: tuple[str, ...] = ()
    #: ``component``, ``group`` (native kernel) or ``loop`` (iterated algebraic loop).
    what: str = "component"
    #: Its place in the execution order (set by the master; the guardian's marker reads it to
    #: tell, after a crash, which of the steps under way came first).
    place: int = -1
    #: Marked with this work just before its step (after its inputs are fed), so that a step
    #: that hangs or crashes is blamed on it; None: nobody watches.
    marker: Marks | None = None

    def feed(self, t: float) -> None:
        """Copy each connection's newest value into this work's inputs."""
        for transfer in self.transfers:
            transfer(t)

    def record_inputs(self) -> None:
        """Record the inputs as the step will use them."""
        if self.before is not None:
            self.before.sample()

    def advance(self, t: float) -> None:
        """Step from ``t`` by ``h``."""
        self.step(t, self.h)

    def record_outputs(self) -> None:
        """Record the outputs the step produced."""
        if self.after is not None:
            self.after.sample()

    def perform(self, t: float) -> None:
        """Feed, record the inputs, mark, advance, record the outputs; a model ending the run
        in its step has completed it: its outputs are recorded, then ``ModelTerminated`` goes
        on."""
        for transfer in self.transfers:
            transfer(t)
        before, after = self.before, self.after
        if before is not None:
            before.sample()
        if self.marker is not None:
            self.marker.work = self
        try:
            self.step(t, self.h)
        except ModelTerminated:
            if after is not None:
                after.sample()
            raise
        if after is not None:
            after.sample()
