"""ROS 2 message definitions kept in the cache folder (``fmionnx.compile.ros2.typecache``):
exactly rosbags' definitions, ignored when tampered with, and a compile that reads them does
not import rosbags' typestores."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fmionnx.compile.ros2 import typecache
from fmionnx.compile.ros2.messages import _STORES, RosDistro, typestore
from tests.keptstores import entries, forge


def _entry(distro: RosDistro) -> Path:
    entry = typecache._entry(_STORES[distro].value)
    assert entry is not None
    return entry.file


@pytest.mark.parametrize("distro", list(RosDistro))
def test_kept_definitions_are_rosbags_own(distro: RosDistro) -> None:
    store = _STORES[distro].value
    expected = typestore(distro).fielddefs
    first = typecache.kept_fielddefs(store, lambda: expected)
    assert _entry(distro).is_file()
    kept = typecache.kept_fielddefs(store, lambda: pytest.fail("read from rosbags again"))
    assert first is expected
    assert kept == expected
    for name, (constants, fields) in kept.items():  # lists, tuples and node types alike
        original_constants, original_fields = expected[name]
        assert type(constants) is type(original_constants)
        assert [type(c) for c in constants] == [type(c) for c in original_constants]
        assert [(f, type(d[0])) for f, d in fields] == [(f, type(d[0])) for f, d in original_fields]


def test_a_tampered_entry_is_ignored_and_written_again() -> None:
    distro = RosDistro.HUMBLE
    store = _STORES[distro].value
    expected = typestore(distro).fielddefs
    typecache.kept_fielddefs(store, lambda: expected)
    path = _entry(distro)
    forge(path, b'"float64"', b'"float32"')
    calls: list[int] = []

    def load() -> typecache.Fielddefs:
        calls.append(1)
        return expected

    assert typecache.kept_fielddefs(store, load) == expected
    assert calls == [1]
    assert typecache.kept_fielddefs(store, load) == expected  # written again, read back
    assert calls == [1]


def test_entries_of_the_first_format_are_removed() -> None:
    """Format 1 kept each distribution in a flat file, which eviction never removes."""
    distro = RosDistro.HUMBLE
    root = _entry(distro).parent.parent
    root.mkdir(mode=0o700, parents=True, exist_ok=True)
    flat = root / ("0" * 40 + ".json")
    flat.write_text("{}")
    typecache.kept_fielddefs(_STORES[distro].value, lambda: typestore(distro).fielddefs)
    assert not flat.exists()
    assert _entry(distro).is_file()


def test_switched_off_nothing_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(typecache.STORE.switch, "0")
    distro = RosDistro.HUMBLE
    expected = typestore(distro).fielddefs
    assert typecache.kept_fielddefs(_STORES[distro].value, lambda: expected) is expected
    assert not _entry(distro).exists()
    assert entries(typecache.STORE) == []


CHECK = """
import sys
from fmionnx.compile.ros2.messages import message_types, resolve_field
assert "geometry_msgs/msg/Twist" in message_types()
assert resolve_field("geometry_msgs/msg/Twist", "linear.x").base == "float64"
print(sorted(m for m in sys.modules if m.startswith("rosbags.typesys.stores.")))
"""


def test_the_compiles_questions_are_answered_without_the_typestore() -> None:
    """The first process reads rosbags' store and keeps it; the next one imports none."""
    env = dict(os.environ)
    runs = [
        subprocess.run(
            [sys.executable, "-c", CHECK], env=env, capture_output=True, text=True, check=True
        ).stdout.strip()
        for _ in range(2)
    ]
    assert runs[0] != "[]"
    assert runs[1] == "[]"
