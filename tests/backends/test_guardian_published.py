"""The guardian's reader of rows published while the guarded run goes on.

The rows are written by the child (here: the child's recorder, in this process, on a real
shared file); the reader reads only complete rows, follows tracks that grow and move, and
believes nothing the child could have forged: a directory pointing outside the file, counts
beyond a region, or a file truncated under it (the file is sealed against shrinking).
"""

from __future__ import annotations

import mmap
import os
from typing import Any

import numpy as np
import pytest

from fmionnx.runtime import guardian, recorder
from fmionnx.runtime.guardian import SharedRecorder, _Shared
from fmionnx.runtime.published import Published


def _reader(memory: _Shared, steps: int = 1_000_000) -> Published:
    return Published(memory.fd, memory.directory, steps, sealed=memory.sealed)


def _two_rates(steps: int) -> tuple[recorder.Track, recorder.Track, np.ndarray, np.ndarray]:
    fast_value, slow_value = np.zeros(2), np.zeros(1)
    rec = SharedRecorder()
    fast = rec.track(1, steps)
    fast.add(["a.x", "a.y"], fast_value)
    slow = rec.track(3, steps)
    slow.add(["b.z"], slow_value)
    rec.order.extend(["b.z", "a.x", "a.y"])
    for track in (fast, slow):
        track.allocate()
    return fast, slow, fast_value, slow_value


def test_published_rows_are_read_at_base_steps_as_the_recorder_holds_them(
    shared: _Shared,
) -> None:
    fast, slow, fast_value, slow_value = _two_rates(100)
    reader = _reader(shared)
    assert reader.refresh() == 0  # nothing recorded yet
    for n in range(10):
        fast_value[:] = (n, -n)
        fast.sample()
        if n % 3 == 0:
            slow_value[:] = 100 + n
            slow.sample()
    assert reader.refresh() == 10  # fast: 10 rows; slow: 4 rows of 3 steps each
    assert reader.names == ["b.z", "a.x", "a.y"]  # the recorder's order
    values = reader.values(np.arange(10, dtype=np.int64))
    np.testing.assert_array_equal(values[:, 1], np.arange(10))
    np.testing.assert_array_equal(values[:, 0], [100, 100, 100, 103, 103, 103, 106, 106, 106, 109])
    with pytest.raises(ValueError, match="beyond what is published"):
        reader.values(np.arange(8, 11, dtype=np.int64))
    reader.close()


def test_tracks_that_grow_and_move_are_followed(shared: _Shared) -> None:
    steps = recorder.CHUNK_ROWS + 500  # beyond the rows a track reserves first
    value = np.zeros(1)
    rec = SharedRecorder()
    track = rec.track(1, steps)
    track.add(["x"], value)
    rec.order.append("x")
    track.allocate()
    reader = _reader(shared)
    for n in range(recorder.CHUNK_ROWS):
        value[0] = n
        track.sample()
    assert reader.refresh() == recorder.CHUNK_ROWS
    for n in range(recorder.CHUNK_ROWS, steps):
        value[0] = n
        track.sample()  # the first of these moved the rows to a new region
    assert reader.refresh() == steps
    tail = np.arange(steps - 600, steps, dtype=np.int64)
    np.testing.assert_array_equal(reader.values(tail)[:, 0], tail)
    reader.close()


def _pages_can_be_removed() -> bool:
    """Whether this kernel frees a shared file's pages on ``MADV_REMOVE`` (not gVisor's)."""
    try:
        with mmap.mmap(-1, mmap.PAGESIZE) as probe:
            probe.madvise(mmap.MADV_REMOVE)
    except (AttributeError, OSError, ValueError):
        return False
    return True


@pytest.mark.skipif(not _pages_can_be_removed(), reason="no MADV_REMOVE here: the pages stay")
def test_a_track_that_grew_holds_the_memory_of_its_last_region_only(shared: _Shared) -> None:
    """Each region a track outgrows is given back: the file only grows (it is sealed against
    shrinking), and the rows took twice their size in memory before."""
    steps = 8 * recorder.CHUNK_ROWS  # moves three times: 1, 2, 4, then 8 chunks of rows
    values = np.zeros(4)
    rec = SharedRecorder()
    track = rec.track(1, steps)
    track.add(["a", "b", "c", "d"], values)
    rec.order.extend(["a", "b", "c", "d"])
    track.allocate()
    for n in range(steps):
        values[0] = n
        track.sample()
    last_region = 8 + steps * 4 * 8
    allocated = os.fstat(shared.fd).st_blocks * 512
    regions = os.fstat(shared.fd).st_size - guardian.CONTROL
    assert regions > 1.8 * last_region  # the file still spans every region it had
    assert allocated < 1.2 * last_region + guardian.CONTROL  # its memory: the last one
    reader = _reader(shared)
    assert reader.refresh() == steps  # the directory names the last region, whole
    every = np.arange(steps, dtype=np.int64)
    np.testing.assert_array_equal(reader.values(every)[:, 0], every)
    reader.close()


def test_a_region_stays_while_the_directory_in_use_names_it(
    shared: _Shared, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A directory too large for its slot is not published; the one in use, which names the
    old region, stays, and so do that region's rows (the guardian reads them after a crash)."""
    value = np.zeros(1)
    rec = SharedRecorder()
    track = rec.track(1, 2 * recorder.CHUNK_ROWS)
    track.add(["x"], value)
    rec.order.append("x")
    track.allocate()
    for n in range(recorder.CHUNK_ROWS):
        value[0] = n
        track.sample()
    monkeypatch.setattr(shared, "publish", lambda directory: False)  # as one too large
    value[0] = -1
    track.sample()  # moves to a new region, which no directory names
    reader = _reader(shared)
    assert reader.refresh() == recorder.CHUNK_ROWS  # the old region, still whole
    tail = np.arange(recorder.CHUNK_ROWS - 10, recorder.CHUNK_ROWS, dtype=np.int64)
    np.testing.assert_array_equal(reader.values(tail)[:, 0], tail)
    reader.close()


def test_the_shared_file_cannot_be_truncated_under_the_reader(shared: _Shared) -> None:
    assert shared.sealed
    with pytest.raises(PermissionError):
        os.ftruncate(shared.fd, 4096)  # what a hostile child would do to crash the guardian
    os.ftruncate(shared.fd, os.fstat(shared.fd).st_size + 4096)  # growing is allowed


def test_an_unsealed_file_is_not_read_while_the_child_runs(shared: _Shared) -> None:
    fast, _, _, _ = _two_rates(10)
    fast.sample()
    assert Published(shared.fd, shared.directory, 10, sealed=False).refresh() == 0


@pytest.mark.parametrize(
    "forged",
    [
        {"offset": 1 << 40, "capacity": 1, "columns": ["x"], "period": 1},  # beyond the file
        {"offset": 1 << 20, "capacity": 1 << 40, "columns": ["x"], "period": 1},
        {"offset": -8, "capacity": 1, "columns": ["x"], "period": 1},
        {"offset": 1 << 20, "capacity": 1, "columns": ["x"], "period": 0},
        {"offset": True, "capacity": 1, "columns": ["x"], "period": 1},
        {"offset": 1 << 20, "capacity": 1, "columns": [3], "period": 1},
        {"offset": 1 << 20, "capacity": 1, "columns": "x", "period": 1},
        {"offset": 1.5, "capacity": 1, "columns": ["x"], "period": 1},
        "not a track",
    ],
)
def test_a_forged_directory_is_not_believed(shared: _Shared, forged: Any) -> None:
    shared.publish({"tracks": [forged], "order": ["x"], "works": []})
    reader = _reader(shared)
    assert reader.refresh() == 0
    assert reader.names == []
    reader.close()


def test_a_forged_row_count_is_clamped_to_its_region(shared: _Shared) -> None:
    fast, _, _, _ = _two_rates(10)  # 12 rows of capacity
    fast.sample()
    directory = shared.directory()
    assert directory is not None
    offset = directory["tracks"][0]["offset"]
    os.pwrite(shared.fd, (10**15).to_bytes(8, "little"), offset)  # the child's own write
    reader = _reader(shared)
    # the slow track has no row: left out, as the recorder leaves it out of the table
    assert reader.refresh() == fast.capacity
    assert reader.names == ["a.x", "a.y"]
    assert reader.values(np.arange(fast.capacity, dtype=np.int64)).shape == (fast.capacity, 2)
    reader.close()


def test_a_torn_or_hostile_directory_text_is_no_directory(shared: _Shared) -> None:
    shared.publish({"tracks": []})
    start = guardian._CELLS * 8 + (int(shared.cells[guardian._DIRECTORY]) - 1) * guardian._SLOT
    shared.control[start : start + 8] = (1 << 62).to_bytes(8, "little")  # a length beyond it
    assert shared.directory() is None  # read up to the slot's end: not JSON, and no error
    shared.control[start + 8 : start + 12] = b"[1, "  # not an object
    shared.control[start : start + 8] = (4).to_bytes(8, "little")
    assert shared.directory() is None
    assert _reader(shared).refresh() == 0
