"""When a node publishes a topic, and how many samples a reader must have seen before it steps.

Lockstep runs reproduce the in-process master (``docs/execution.md``) without a per-sample
sequence number on the wire (``std_msgs/msg/Float64`` has no header): every node derives, from
the compiled system alone, how many samples each producer has published on a topic before a
given point of the schedule. A point is a *key* ``(n, position)``: base step ``n`` and the
component's index in ``CompiledSystem.order``; the initial values published after set-up have
step ``-1``. A consumer due at ``(n, pos)`` reads sample number ``count_before(n, pos)``: the
value the in-process master would copy (the producer's step-``n`` output when it runs earlier
in the order, otherwise the one it published last: held values).

Image topics are *lazy*, like camera outputs in-process: rendered and published only after a
producer step whose state some consumer reads (the window from that step to the producer's
next one). An image topic without a consumer inside the run is published at 10 Hz.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.fields import IMAGE_TYPE
from fmionnx.compile.ros2.types import Ros2Plan, TopicPlan
from fmionnx.kinds.base import EVALUATED_AT_START
from fmionnx.kinds.registry import has_capability

#: Rate of an image topic that nothing inside the run reads (for viewers such as rviz).
UNREAD_IMAGE_RATE = 10.0


@dataclass(frozen=True, slots=True)
class Reader:
    """A consumer of a topic: its period in base steps and its position in the order.

    ``at_start``: it computes its outputs at the start time from its inputs there (an ONNX
    model, ``kinds.base.EVALUATED_AT_START``), so it reads the values published after set-up.
    """

    period: int
    position: int
    at_start: bool = False


@dataclass
class TopicSchedule:
    """The publication rule of one topic with a publisher inside the run."""

    topic: str
    period: int
    position: int
    lazy: bool
    readers: tuple[Reader, ...]
    every: int = 1
    _next: int = field(default=0, repr=False)
    _counted: int = field(default=0, repr=False)

    def published_at_init(self) -> bool:
        """Whether the values after set-up are published (always, unless lazy and unread)."""
        if not self.lazy:
            return True
        return any(r.position < self.position or r.at_start for r in self.readers)

    def published_at(self, m: int) -> bool:
        """Whether the producer publishes after its step at base step ``m`` (``m % period == 0``)."""
        if not self.lazy:
            return True
        if not self.readers:
            return (m // self.period) % self.every == 0
        end = m + self.period
        for reader in self.readers:
            first = m if reader.position > self.position else m + 1
            last = end if reader.position < self.position else end - 1
            # a multiple of the reader's period inside [first, last]?
            candidate = -(-first // reader.period) * reader.period
            if candidate <= last:
                return True
        return False

    def count_before(self, n: int, position: int) -> int:
        """Samples published with a key before ``(n, position)``; queries must not go back."""
        while self._next < n or (self._next == n and self.position < position):
            if self.published_at(self._next):
                self._counted += 1
            self._next += self.period
        return self._counted + (1 if self.published_at_init() else 0)


def topic_schedules(system: CompiledSystem, plan: Ros2Plan) -> dict[str, TopicSchedule]:
    """A fresh schedule (its own counter) for every topic published inside the run."""
    position = {name: i for i, name in enumerate(system.order)}
    schedules = {}
    for topic in plan.topics:
        if topic.publisher is None:
            continue
        producer = system.component(topic.publisher)
        readers = tuple(
            dict.fromkeys(
                Reader(
                    system.component(s.component).period_steps,
                    position[s.component],
                    has_capability(system.component(s.component), EVALUATED_AT_START),
                )
                for s in plan.subscriptions
                if s.topic == topic.name
            )
        )
        seconds = producer.period_steps * system.run.step
        every = max(1, round(1.0 / (UNREAD_IMAGE_RATE * seconds)))
        schedules[topic.name] = TopicSchedule(
            topic.name,
            producer.period_steps,
            position[topic.publisher],
            is_lazy(topic),
            readers,
            every,
        )
    return schedules


def is_lazy(topic: TopicPlan) -> bool:
    """Image topics are published only when read (rendering costs milliseconds)."""
    return topic.msgtype == IMAGE_TYPE
