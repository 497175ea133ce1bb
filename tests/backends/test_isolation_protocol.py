"""The supervisor trusts nothing an isolated model's process sends it.

The child runs a model that may be hostile and can write to its reply pipe and to the shared
block. Its replies are bounded JSON checked field by field (never a pickle, which would run
code in the supervisor), the layout it reports cannot place a view outside the shared block,
and the shared file cannot be shrunk under the supervisor's mapping.
"""

from __future__ import annotations

import os
import pickle
import struct
from pathlib import Path

import pytest

from fmionnx.runtime.isolated import channel
from fmionnx.runtime.isolated.channel import Layout, Slot
from fmionnx.runtime.isolated.proxy import _memory_file

PORTS = frozenset({"u", "y"})


class _Planted:
    """Unpickling this writes a file: the proof that a pickle was loaded."""

    def __init__(self, path: str) -> None:
        self.path = path

    def __reduce__(self) -> tuple[object, tuple[str, str]]:
        return (Path.write_text, (Path(self.path), "code ran in the supervisor"))  # type: ignore[return-value]


def _pipe_with(data: bytes) -> int:
    read, write = os.pipe()
    os.write(write, data)
    os.close(write)
    return read


def test_a_pickled_reply_is_refused_unloaded(tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    payload = pickle.dumps(_Planted(str(marker)))
    fd = _pipe_with(struct.pack("<I", len(payload)) + payload)
    with pytest.raises(channel.MalformedReplyError, match="not JSON"):
        channel.receive_reply(fd)
    assert not marker.exists()


def test_an_oversized_reply_is_refused_before_it_is_read() -> None:
    fd = _pipe_with(struct.pack("<I", channel.MAX_REPLY_BYTES + 1))
    with pytest.raises(channel.MalformedReplyError, match="at most"):
        channel.receive_reply(fd)


def _document(*slots: list[object], size: int = 16) -> dict[str, object]:
    return {"slots": list(slots), "size": size, "lazy_outputs": [], "step_labels": ["fmi2DoStep"]}


def test_a_well_formed_layout_is_accepted() -> None:
    layout = channel.parse_layout(
        _document(["u", True, "<f8", 0, 1], ["y", False, "<f8", 8, 1]), PORTS, 16
    )
    assert layout == Layout(
        (Slot("u", True, "<f8", 0, 1), Slot("y", False, "<f8", 8, 1)), 16, frozenset(),
        ("fmi2DoStep",),
    )  # fmt: skip


@pytest.mark.parametrize(
    ("slot", "size", "problem"),
    [
        (["u", True, "<f8", 8, 2], 16, "outside the shared block"),  # reaches past the end
        (["u", True, "<f8", -8, 1], 16, "outside the shared block"),
        (["nope", True, "<f8", 0, 1], 16, "unknown port"),
        (["u", True, "O", 0, 1], 16, "of type"),  # object pointers
        (["u", True, "<U8", 0, 1], 64, "of type"),
        (["u", True, "<f8", 0, True], 16, "non-integer"),
        (["u", True, "<f8", 0.5, 1], 16, "non-integer"),
        (["u", "yes", "<f8", 0, 1], 16, "unknown port"),
        (["u", True], 16, "malformed layout"),
        (["u", True, "<f8", 0, 1], 1 << 40, "larger than the shared block"),
    ],
)
def test_a_hostile_layout_is_refused(slot: list[object], size: int, problem: str) -> None:
    with pytest.raises(channel.MalformedReplyError, match=problem):
        channel.parse_layout(_document(slot, size=size), PORTS, 16)


def test_error_replies_are_bounded_and_typed() -> None:
    message, port, time, kind, _ = channel.parse_error(["x" * 10_000, {"evil": 1}, "soon"])
    assert len(message) == 2000
    assert (port, time, kind) == (None, None, None)
    with pytest.raises(channel.MalformedReplyError):
        channel.parse_error({"not": "a triple"})
    with pytest.raises(channel.MalformedReplyError):
        channel.parse_error(["one", "two"])


def test_the_shared_file_cannot_shrink_under_the_supervisors_mapping() -> None:
    if not hasattr(os, "memfd_create"):
        pytest.skip("memfd sealing is Linux only")
    handle = _memory_file("probe")
    try:
        os.ftruncate(handle, channel.CONTROL_SIZE * 4)  # the child may grow it
        with pytest.raises(PermissionError):
            os.ftruncate(handle, 0)
    finally:
        os.close(handle)
