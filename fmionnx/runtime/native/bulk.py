"""Many communication points per C call, when one native group is the whole schedule.

A lone FMU, or a chain of FMUs of one rate, is one native group (:mod:`.group`) that is due at
every base step. Stepped one communication point per call, the master's Python loop costs
about 2 µs a step around a C call that, for a small FMU, takes a tenth of that: three
quarters of a lone FMU's loop. Here ``fx_group_run`` steps many points per call and appends
the recorder's rows itself, exactly as :meth:`.group.NativeGroup.step` and
:meth:`fmionnx.runtime.recorder.Track.sample` would have: the same times (``start + n *
step``), the same values converted to float64 as numpy converts them, the row before its
count, which the guardian's shared tracks publish after each row.

The master calls :meth:`BulkLoop.run` in *chunks* that end where its Python loop would do
something between two steps: a progress call (every ``progress_every`` steps), a checkpoint
(checked before each chunk), a stop request (a signal is handled when the call returns: a
call returns after :data:`CHUNK_SECONDS` of wall time, between two steps), a track that needs
room (it grows, in Python, and the chunk goes on). A fault ends the chunk at the failed step,
which the master then settles with the group's own fault handling, as in the Python loop.

The watchdog of a run in this process reads the marker, which the master moves on after each
chunk; a chunk is cut short after :data:`CHUNK_SECONDS`, so only a step that itself overruns
the timeout goes unmarked, and :meth:`BulkLoop.under_way` then says which step it is. The
guardian's marker keeps its time in shared memory, where the kernel stores it before each
step, as the Python loop does.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence

from fmionnx.runtime.native import kernel as k
from fmionnx.runtime.native.group import NativeGroup, type_code
from fmionnx.runtime.recorder import Track

#: Wall time after which a call returns between two steps: how late a stop request, a
#: checkpoint or the watchdog's view of the marker can be.
CHUNK_SECONDS = 0.01


def views_problem(tracks: Sequence[Track]) -> str | None:
    """Why the kernel cannot sample ``tracks`` as :meth:`Track.sample` does, or None."""
    for track in tracks:
        for view, _, _ in track.views:
            if type_code(view.dtype) is None:
                return f"a recorded buffer holds {view.dtype} values"
            if not view.flags.c_contiguous:
                return "a recorded buffer is not contiguous"
    return None


class BulkLoop:
    """Steps one native group over many base steps per call, sampling ``tracks`` after each."""

    def __init__(
        self,
        kernel: k.Kernel,
        group: NativeGroup,
        tracks: Sequence[Track],
        *,
        start: float,
        step: float,
        h: float,
        marker_t: int | None,
    ) -> None:
        self.group = group
        self._tracks = tuple(tracks)
        self._run_fn = kernel.run
        views = [(view, column) for t in self._tracks for view, column, _ in t.views]
        self._views = (k.ViewSpec * max(1, len(views)))()
        for spec, (view, column) in zip(self._views, views, strict=False):
            code = type_code(view.dtype)
            assert code is not None  # views_problem was asked first
            spec.src, spec.count, spec.column, spec.type = view.ctypes.data, view.size, column, code
        self._specs = (k.TrackSpec * max(1, len(self._tracks)))()
        first = 0
        for spec, track in zip(self._specs, self._tracks, strict=False):
            spec.width = len(track.columns)
            spec.first_view, spec.n_views = first, len(track.views)
            first += len(track.views)
            self._place(spec, track)
        self._run = k.RunSpec(
            start, step, h, len(self._tracks), ctypes.addressof(self._specs),
            ctypes.addressof(self._views), marker_t or 0, CHUNK_SECONDS, 0,
        )  # fmt: skip
        self._group_address = group.address
        self._run_address = ctypes.addressof(self._run)

    @staticmethod
    def _place(spec: k.TrackSpec, track: Track) -> None:
        """Point ``spec`` at ``track``'s rows (again after they moved)."""
        spec.rows = track.rows.ctypes.data
        spec.published = track.count_address()
        spec.capacity = len(track.rows)
        spec.count = track.count

    def run(self, first: int, last: int) -> tuple[int, int]:
        """Step from base step ``first`` towards ``last``: (code, the first step not done).

        Code :data:`.kernel.OK` with the step below ``last``: the chunk's wall time ran out.
        Any other code is the group's fault at that step (:meth:`NativeGroup.fault`). The
        tracks' counts are brought up to date before this returns.
        """
        while True:
            code = self._run_fn(self._group_address, self._run_address, first, last)
            first = self._counted()
            if code != k.FULL:
                return code, first
            for spec, track in zip(self._specs, self._tracks, strict=False):
                if track.count >= len(track.rows):
                    track.reserve()
                    self._place(spec, track)

    def under_way(self) -> int:
        """The base step a call is in (read from another thread while the call is stuck in a
        model's step: the watchdog's), with the tracks' counts brought up to date."""
        return self._counted()

    def _counted(self) -> int:
        """The tracks' counts as the kernel left them, copied to the tracks; the run's next
        step."""
        for spec, track in zip(self._specs, self._tracks, strict=False):
            track.count = spec.count
        return int(self._run.next)
