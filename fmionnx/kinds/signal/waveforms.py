"""Waveforms in their resolved, frozen form: pure functions of the time.

Each has ``at(t)`` (the value at ``t``, computed afresh: nothing accumulates) and its
``breakpoints`` (times where it jumps or bends, which the runner snaps to; see
:data:`fmionnx.kinds.signal.runner.SNAP`). They are the kind's config, so they are frozen
dataclasses that ``dataclasses.asdict`` can hash.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from fmionnx.core.types import KindConfig
from fmionnx.kinds.signal.names import NAME

if TYPE_CHECKING:  # pydantic: the entry's models load only to compile a system file
    from fmionnx.kinds.signal.spec import OutputSpec


@dataclass(frozen=True, slots=True)
class Constant:
    """A constant value."""

    value: float

    def at(self, t: float) -> float:
        """The value at time ``t``."""
        return self.value

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times where the value jumps or bends."""
        return ()

    def text(self) -> str:
        """One line for ``inspect``."""
        return f"constant {self.value:g}"


@dataclass(frozen=True, slots=True)
class Step:
    """``initial`` before ``time``, ``final`` from ``time`` on."""

    time: float
    initial: float
    final: float

    def at(self, t: float) -> float:
        """The value at time ``t`` (``final`` at ``t == time``)."""
        return self.final if t >= self.time else self.initial

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times where the value jumps or bends."""
        return (self.time,)

    def text(self) -> str:
        """One line for ``inspect``."""
        return f"step from {self.initial:g} to {self.final:g} at {self.time:g} s"


@dataclass(frozen=True, slots=True)
class Ramp:
    """``initial`` until ``time``, then ``initial + slope * (t - time)``."""

    time: float
    initial: float
    slope: float

    def at(self, t: float) -> float:
        """The value at time ``t``."""
        return self.initial if t <= self.time else self.initial + self.slope * (t - self.time)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times where the value jumps or bends."""
        return (self.time,)

    def text(self) -> str:
        """One line for ``inspect``."""
        return f"ramp from {self.initial:g} at {self.time:g} s, slope {self.slope:g}/s"


@dataclass(frozen=True, slots=True)
class RampTo:
    """``initial`` until ``time``, a line to ``final`` over ``duration``, then ``final``."""

    time: float
    initial: float
    final: float
    duration: float

    def at(self, t: float) -> float:
        """The value at time ``t``: exactly ``initial`` and ``final`` at the ends."""
        if t <= self.time:
            return self.initial
        if t >= self.time + self.duration:
            return self.final
        return self.initial + (self.final - self.initial) * ((t - self.time) / self.duration)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times where the value jumps or bends."""
        return (self.time, self.time + self.duration)

    def text(self) -> str:
        """One line for ``inspect``."""
        return (
            f"ramp from {self.initial:g} at {self.time:g} s to {self.final:g} "
            f"at {self.time + self.duration:g} s"
        )


@dataclass(frozen=True, slots=True)
class Sine:
    """``offset + amplitude * sin(2π * frequency * t + phase)``."""

    amplitude: float
    frequency: float
    phase: float
    offset: float

    def at(self, t: float) -> float:
        """The value at time ``t``."""
        return self.offset + self.amplitude * math.sin(
            2.0 * math.pi * self.frequency * t + self.phase
        )

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times where the value jumps or bends."""
        return ()

    def text(self) -> str:
        """One line for ``inspect``."""
        return (
            f"sine {self.amplitude:g} * sin(2π * {self.frequency:g} Hz * t + {self.phase:g}) "
            f"+ {self.offset:g}"
        )


Waveform = Constant | Step | Ramp | RampTo | Sine


def waveform(spec: OutputSpec) -> Waveform:
    """The frozen waveform of a checked output entry."""
    if spec.step is not None:
        return Step(spec.step.time, spec.step.initial, spec.step.final)
    if spec.ramp is not None:
        ramp = spec.ramp
        if ramp.slope is not None:
            return Ramp(ramp.time, ramp.initial, ramp.slope)
        assert ramp.final is not None
        assert ramp.duration is not None
        return RampTo(ramp.time, ramp.initial, ramp.final, ramp.duration)
    if spec.sine is not None:
        sine = spec.sine
        return Sine(sine.amplitude, sine.frequency, sine.phase, sine.offset)
    assert spec.constant is not None
    return Constant(spec.constant)


@dataclass(frozen=True, slots=True)
class SignalConfig(KindConfig):
    """Resolved settings: the waveform of each output, or (for a table) its interpolation."""

    kind: str = NAME
    outputs: tuple[tuple[str, Waveform], ...] = ()
    interpolation: Literal["linear", "hold"] | None = None
