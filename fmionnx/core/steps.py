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


def time_flags_problem(start: float | None, step: float | None, stop: float | None) -> str | None:
    """Why ``--start-time``/``--step``/``--stop-time`` cannot be run (a sentence naming the
    option), or None. The CLI refuses them as usage errors, ``load(...)`` and a lone model as
    E040: one wording for all three."""
    problem = None if step is None else step_problem(step)
    if problem is not None:
        return f"--step {problem}"
    for option, value in (("--start-time", start), ("--stop-time", stop)):
        if value is not None and not math.isfinite(value):
            return f"{option} {value} must be a finite number of seconds"
    if start is not None and stop is not None and stop <= start:
        return f"--stop-time {stop} must be greater than --start-time {start}"
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


def output_interval_problem(interval: float, step: float) -> str | None:
    """Why ``interval`` cannot separate two rows of results (a phrase), or None when it can.

    Rows exist only at communication points, so the interval is a whole multiple of the base
    step (``run.output_interval``, ``--output-interval``; E047).
    """
    problem = step_problem(interval)
    if problem is not None:
        return problem
    ratio = interval / step
    nearest = round(ratio) if math.isfinite(ratio) else 0
    if nearest < 1 or not math.isclose(ratio, nearest, rel_tol=1e-6, abs_tol=1e-6):
        return f"{interval} is not a whole multiple of the base step {step}"
    if nearest > MAX_EXACT_STEPS:
        return f"{interval} is more than 2**53 base steps of {step}"
    return None


def suggest_interval(interval: float, step: float) -> float:
    """The whole multiple of ``step`` nearest to ``interval`` (at least one step)."""
    ratio = interval / step
    return step * max(1, round(ratio)) if math.isfinite(ratio) and ratio < MAX_EXACT_STEPS else step


#: Most base steps of a run whose step nothing gives (an SSD without one: :func:`default_step`).
DEFAULT_STEPS = 1000


def default_step(length: float) -> float:
    """The base step of a run of ``length`` seconds that nothing else gives a step to.

    SSP has no step size (neither 1.0 nor 2.0), so an SSD from a tool that writes none, with
    models that declare none, still needs one. Like FMPy for an FMU without a default step,
    the step follows the length of the run: the smallest "round" step (1, 2 or 5 times a power
    of ten) that divides the run into at most :data:`DEFAULT_STEPS` steps (a 10 s run: 0.01 s).
    """
    decade = 10.0 ** math.floor(math.log10(length / DEFAULT_STEPS))
    for factor in (1.0, 2.0, 5.0, 10.0):
        step = factor * decade
        if length / step <= DEFAULT_STEPS * (1 + 1e-9):
            return step
    return 10.0 * decade
