"""A node's initial values when its model has no state (ONNX): computed from its start inputs.

The node counterpart of :mod:`fmionnx.runtime.startvalues`. Before a node publishes its values
after set-up, a :class:`~fmionnx.core.runner.StartEvaluating` runner gets the samples its
producers published after their own set-up (a camera's frame at the initial state included:
the producer's schedule publishes it for such a reader, ``schedule.Reader.at_start``) and
computes its outputs from them. Lockstep waits for those samples, as the in-process master
reads them, so the two give the same results. A free run waits for them while it starts (at
most :data:`START_WAIT`, before the node says it is ready: no clock runs yet) and does not
count them among its steps' inputs; a sample that does not come leaves the inputs' start
values. A topic from outside the run gives what has arrived.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from fmionnx.core.runner import Runner, StartEvaluating

if TYPE_CHECKING:
    from fmionnx.backends.ros2.node import Inbox
    from fmionnx.runtime.transfer import Transfer

log = logging.getLogger("fmionnx.node")
#: Seconds a free-run node waits, while it starts, for its producers' values after set-up.
START_WAIT = 30.0


def evaluate_at_start(
    runner: Runner,
    inboxes: Sequence[Inbox],
    transfers: Sequence[Transfer],
    start: float,
    *,
    lockstep: bool,
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
        deadline = time.monotonic() + START_WAIT
        for box, stamp in zip(inboxes, stamps, strict=True):
            _load_start(box, stamp if box.schedule is not None else None, deadline)
    for transfer in transfers:
        transfer(start)
    runner.evaluate_at_start(start)


def _load_start(box: Inbox, stamp: int | None, deadline: float) -> None:
    """Free run: wait (until ``deadline``) for the set-up sample ``stamp`` and load it."""
    assert box.stamped is not None
    box.collect()
    if stamp is not None:
        while stamp not in box.stamped.pending and time.monotonic() < deadline:
            box.reader.wait(min(0.05, max(deadline - time.monotonic(), 0.0)))
            box.collect()
    data = box.stamped.take_start(stamp)
    if data is None:
        if stamp is not None:
            log.info(
                "%s: no values after set-up arrived; starting from its start values", box.topic.name
            )
        return
    values, _ = box.codec.decode(data)
    for port, buffer in box.sinks:
        np.copyto(buffer, values[port].reshape(buffer.shape), casting="unsafe")
