"""Real time in-process (``--rtf X``): the master's base steps held to X times the wall clock.

Base step ``n`` is due to be done ``(n + 1) * step / X`` seconds of wall time after the loop
started: a step done early waits for that moment (a sleep), a step done later is *late* by
the difference. The schedule is absolute, so a run that fell behind catches up as fast as it
can rather than drifting. A step counts as late when it ends more than one step's budget
(``step / X``, at least :data:`MIN_TOLERANCE`) after its moment: below that, a sleep's own
jitter would count.

Besides late steps, the pacer notes *overruns*: base steps whose own work took longer than
the budget, the cause of lateness. For the largest it keeps where the time went, per
component and phase, from the run's :class:`~fmionnx.runtime.profile.Profile` (a paced run is
always profiled: it sleeps most of the time, and the stopwatches cost nothing beside that).
A run *kept up* when it ended on its schedule (at most the tolerance behind): a system that
is faster than X on the whole but has a slow step now and then catches up, and its late steps
are reported without more. A run that ended behind did not keep up and says so: in
:meth:`Pacer.report` (run.json's ``pacing``) and as a warning of the run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from fmionnx.runtime.profile import Profile
from fmionnx.runtime.result import Detail

#: Lateness below this never counts (a sleep wakes up to a millisecond late on a busy machine).
MIN_TOLERANCE = 0.001
#: Components named in the breakdown of the worst overrun.
BREAKDOWN = 4

_clock = time.perf_counter


@dataclass
class _Overrun:
    """The base step that took longest beyond its budget."""

    time: float
    took: float
    by: dict[str, float]


class Pacer:
    """Waits after each base step for its moment; counts late steps and overruns."""

    def __init__(self, rtf: float, start: float, step: float, profile: Profile) -> None:
        self.rtf = rtf
        self.start = start
        self.step = step
        self.budget = step / rtf
        self.tolerance = max(self.budget, MIN_TOLERANCE)
        self.profile = profile
        self.steps = 0
        self.late = 0
        self.max_lateness = 0.0
        self.max_lateness_at: float | None = None
        self.overruns = 0
        self.worst: _Overrun | None = None
        self.lateness = 0.0
        self._origin = 0.0
        self._began = 0.0
        self._before: list[float] = []

    def begin(self) -> None:
        """The loop starts now (step 0's moment is one budget from here)."""
        self._origin = self._began = _clock()
        self._before = self.profile.totals()

    def __call__(self, done: int) -> None:
        """Base steps ``0 .. done - 1`` are done: wait for their moment, or note lateness."""
        if done <= self.steps:
            return
        self.steps = done
        now = _clock()
        took = now - self._began
        if took > self.budget:
            self._overran(done, took)
        moment = self._origin + done * self.budget
        if now < moment:
            time.sleep(moment - now)
            now = _clock()
            self.profile.waited += max(0.0, now - self._began - took)
            self.lateness = 0.0
        else:
            lateness = now - moment
            self.lateness = lateness
            if lateness > self.tolerance:
                self.late += 1
            if lateness > self.max_lateness:
                self.max_lateness = lateness
                self.max_lateness_at = self.start + done * self.step
        self._began = now
        self._before = self.profile.totals()

    def _overran(self, done: int, took: float) -> None:
        self.overruns += 1
        if self.worst is not None and took <= self.worst.took:
            return
        names = list(self.profile.entries)
        after = self.profile.totals()
        spent = {
            name: after[i] - (self._before[i] if i < len(self._before) else 0.0)
            for i, name in enumerate(names)
        }
        top = sorted(spent.items(), key=lambda item: item[1], reverse=True)[:BREAKDOWN]
        self.worst = _Overrun(self.start + (done - 1) * self.step, took, dict(top))

    @property
    def kept_up(self) -> bool:
        """The run ended on its schedule (at most the tolerance behind): late steps it caught
        up with are reported, but a run that kept real time as a whole kept up."""
        return self.lateness <= self.tolerance

    def report(self) -> dict[str, Detail]:
        """run.json's ``pacing``."""
        worst: Detail = None
        if self.worst is not None:
            worst = {
                "time": round(self.worst.time, 9),
                "took": round(self.worst.took, 6),
                "budget": round(self.budget, 9),
                "by": {name: round(seconds, 6) for name, seconds in self.worst.by.items()},
            }
        return {
            "rtf": self.rtf,
            "kept_up": self.kept_up,
            "steps": self.steps,
            "late_steps": self.late,
            "max_lateness": round(self.max_lateness, 6),
            "max_lateness_at": self.max_lateness_at,
            "behind_at_end": round(self.lateness, 6),
            "tolerance": round(self.tolerance, 6),
            "overruns": self.overruns,
            "worst_overrun": worst,
            "waited": round(self.profile.waited, 6),
        }

    def warning(self) -> str | None:
        """The run's warning when it did not keep up (None when it did)."""
        if self.kept_up:
            return None
        text = (
            f"--rtf {self.rtf:g}: the run could not keep up: it ended {self.lateness:.3g} s "
            f"behind; {self.late} of {self.steps} base steps ended late, the latest by "
            f"{self.max_lateness:.3g} s"
        )
        if self.max_lateness_at is not None:
            text += f" (t={self.max_lateness_at:g} s)"
        if self.worst is not None:
            spent = ", ".join(
                f"{name} {seconds * 1e3:.3g} ms" for name, seconds in self.worst.by.items()
            )
            text += (
                f"; the longest step (t={self.worst.time:g} s) took {self.worst.took * 1e3:.3g} ms "
                f"of a {self.budget * 1e3:.3g} ms budget: {spent}"
            )
        return text
