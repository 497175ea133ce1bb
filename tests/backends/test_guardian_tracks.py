"""The guardian's shared tracks: the row count the guardian reads after a crash is the
child's, including after the parallel master took rows back (``Track.truncate``)."""

from __future__ import annotations

import numpy as np

from fmionnx.runtime.guardian import SharedRecorder, _Shared


def _seen_by_the_guardian(memory: _Shared) -> tuple[int, np.ndarray]:
    directory = memory.directory()
    assert directory is not None
    (entry,) = directory["tracks"]
    return memory.rows(entry["offset"], entry["capacity"], len(entry["columns"]))


def test_rows_taken_back_are_taken_back_in_shared_memory(shared: _Shared) -> None:
    value = np.zeros(2)
    track = SharedRecorder().track(1, 10)
    track.add(["x", "y"], value)
    track.allocate()
    for k in range(5):
        value[:] = (k, 10 * k)
        track.sample()
    assert _seen_by_the_guardian(shared)[0] == 5
    track.truncate(3)  # the parallel master takes back the rows issued after a failure
    assert track.count == 3
    count, rows = _seen_by_the_guardian(shared)
    assert count == 3
    np.testing.assert_array_equal(rows, [[0, 0], [1, 10], [2, 20]])
    value[:] = (7, 70)
    track.sample()  # recording goes on after the kept rows
    count, rows = _seen_by_the_guardian(shared)
    assert count == 4
    np.testing.assert_array_equal(rows[-1], [7, 70])
    track.truncate(9)  # never more rows than recorded
    assert _seen_by_the_guardian(shared)[0] == track.count == 4
