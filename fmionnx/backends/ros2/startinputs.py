"""A node's initial values when its model has no state (ONNX): computed from its start inputs.

The node counterpart of :mod:`fmionnx.runtime.startvalues`. Before a node publishes its values
after set-up, a :class:`~fmionnx.core.runner.StartEvaluating` runner gets the samples its
producers published after their own set-up (a camera's frame at the initial state included:
the producer's schedule publishes it for such a reader, ``schedule.Reader.at_start``) and
computes its outputs from them. Lockstep waits for those samples, as the in-process master
reads them, so the two give the same results; a free run waits at most ``--input-wait`` and
counts that wait like a step's (matched or stale). A topic from outside the run gives what
has arrived.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

from fmionnx.core.runner import Runner, StartEvaluating

if TYPE_CHECKING:
    from fmionnx.backends.ros2.node import Inbox
    from fmionnx.runtime.transfer import Transfer


def evaluate_at_start(
    runner: Runner,
    inboxes: Sequence[Inbox],
    transfers: Sequence[Transfer],
    start: float,
    *,
    lockstep: bool,
    input_wait: float,
) -> None:
    """Load the set-up samples of every input, copy them in, compute the start outputs.

    Does nothing for a runner with a state of its own (its set-up gave its initial values).
    """
    if not isinstance(runner, StartEvaluating):
        return
    # the stamp (base step) of a producer's values after set-up; None: none are published
    stamps = [
        0 if box.schedule is not None and box.schedule.published_at_init() else None
        for box in inboxes
    ]
    if lockstep:
        for box, stamp in zip(inboxes, stamps, strict=True):
            if box.schedule is None:
                box.newest()
            else:
                box.exact(1 if stamp is not None else 0)
    else:
        deadline = time.monotonic() + input_wait
        for box, stamp in zip(inboxes, stamps, strict=True):
            box.settle(stamp, deadline)
        for box, stamp in zip(inboxes, stamps, strict=True):
            box.load(stamp, start)
    for transfer in transfers:
        transfer(start)
    runner.evaluate_at_start(start)
