"""Limits on time steps and step counts, shared by the compiler, the overrides and ``run``.

A run is ``start + n * step`` for ``n`` up to ``(stop - start) / step``, with every component
stepping every ``period / step`` base steps. Each of these numbers must be an exact, finite
whole number, or the run fails late (an ``OverflowError`` after hours of simulation) or never
ends. The checks here turn such settings into one clear sentence where they are read.
"""

from __future__ import annotations

import math
import sys

#: Smallest base step: the smallest *normal* double. A subnormal step (``5e-324``) has almost
#: no precision left, so ``n * step`` would not give the communication points it promises.
MIN_STEP = sys.float_info.min
#: Most base steps a count may have: beyond 2**53 consecutive whole numbers are no longer
#: exact doubles, so ``start + n * step`` would skip or repeat communication points.
MAX_EXACT_STEPS = 2**53
#: ``validate`` (and ``run``) warn (W040) above this many base steps: hours of run time.
WARN_STEPS = 10**8
#: ``run`` refuses more base steps than this unless ``--max-steps`` allows more.
MAX_RUN_STEPS = 10**10


def step_problem(step: float) -> str | None:
    """Why ``step`` cannot be a time step (a sentence), or None when it can."""
    if not math.isfinite(step) or step <= 0:
        return f"{step} is not a positive finite number of seconds"
    if step < MIN_STEP:
        return f"{step} is subnormal (below {MIN_STEP:.4g}): it has no precision left"
    return None


def count_problem(length: float, step: float, what: str) -> str | None:
    """Why ``length / step`` base steps cannot be counted exactly (a sentence), or None.

    ``what`` names the length in the sentence (``the run``, ``period 1e300``).
    """
    if not math.isfinite(length):
        return f"{what} is longer than the largest float"
    ratio = length / step
    if not math.isfinite(ratio) or ratio > MAX_EXACT_STEPS:
        return f"{what} is more than 2**53 base steps of {step}, too many to count exactly"
    return None
