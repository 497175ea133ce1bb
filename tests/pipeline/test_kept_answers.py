"""The store every kept model answer uses (:class:`fmionnx.core.keptentries.KeptAnswers`):
keys that follow what the answer depends on, entries that check out only for their key and
this user, read back whole or not at all, and a store bounded as the compile cache is."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from fmionnx.core.datacodec import Codec
from fmionnx.core.keptentries import KeptAnswers
from tests.keptstores import entries, forge

STORE = KeptAnswers(switch="FMIONNX_TEST_ANSWERS", folder="test-answers", format="t-1",
                    max_bytes=4096)  # fmt: skip


@dataclass(frozen=True)
class Answer:
    name: str
    sizes: tuple[int, ...]


CODEC = Codec("test answer")


def test_an_answer_is_read_back_as_written() -> None:
    entry = STORE.entry(["model", "digest"])
    assert STORE.read_value(entry, CODEC, Answer) is None
    STORE.write_value(entry, CODEC, Answer("a", (1, 2)))
    assert STORE.read_value(entry, CODEC, Answer) == Answer("a", (1, 2))
    assert entries(STORE) == [entry.file]
    assert entry.file.stat().st_mode & 0o077 == 0
    assert entry.file.parent.stat().st_mode & 0o077 == 0


def test_the_key_follows_the_parts_and_the_limits_in_force(monkeypatch: pytest.MonkeyPatch) -> None:
    first = STORE.entry(["model", "digest"])
    assert STORE.entry(["model", "digest"]) == first
    assert STORE.entry(["model", "other digest"]) != first
    monkeypatch.setenv("FMIONNX_MAX_STEPS", "7")
    assert STORE.entry(["model", "digest"]) != first
    monkeypatch.setenv("FMIONNX_CACHE_MAX_DAYS", "3")  # where and how long, not what
    monkeypatch.setenv("FMIONNX_COMPILE_CACHE", "0")
    with_limit = STORE.entry(["model", "digest"])
    assert with_limit != first
    monkeypatch.delenv("FMIONNX_CACHE_MAX_DAYS")
    monkeypatch.delenv("FMIONNX_COMPILE_CACHE")
    assert STORE.entry(["model", "digest"]) == with_limit
    unkeyed = KeptAnswers("S", "test-answers", "t-1", 4096, keyed_by_environment=False)
    keyed_elsewhere = unkeyed.entry(["model", "digest"])
    monkeypatch.delenv("FMIONNX_MAX_STEPS")
    assert unkeyed.entry(["model", "digest"]) == keyed_elsewhere


def test_an_entry_checks_out_only_for_its_own_key() -> None:
    one, other = STORE.entry(["one"]), STORE.entry(["other"])
    STORE.write(one, b'{"name":"one","sizes":[]}')
    other.file.parent.mkdir(mode=0o700)
    other.file.write_bytes(one.file.read_bytes())  # copied under another key's name
    other.file.chmod(0o600)
    assert STORE.read(one) is not None
    assert STORE.read(other) is None


def test_a_forged_oversized_or_shared_entry_is_ignored() -> None:
    entry = STORE.entry(["model"])
    STORE.write_value(entry, CODEC, Answer("honest", ()))
    assert STORE.read(entry) is not None
    forge(entry.file, b"honest", b"forged")
    assert STORE.read(entry) is None
    STORE.write_value(entry, CODEC, Answer("x" * 5000, ()))  # larger than the bound
    assert entry.file.stat().st_size > STORE.max_bytes
    assert STORE.read(entry) is None
    STORE.write_value(entry, CODEC, Answer("honest", ()))
    assert STORE.read(entry) is not None
    entry.file.parent.chmod(0o777)  # a folder others may write into
    assert STORE.read(entry) is None


@pytest.mark.parametrize("linked", ["file", "folder", "root"])
def test_an_entry_reached_through_a_link_is_ignored(linked: str, tmp_path: Path) -> None:
    entry = STORE.entry(["model"])
    STORE.write_value(entry, CODEC, Answer("honest", ()))
    assert STORE.read(entry) is not None
    place = {"file": entry.file, "folder": entry.file.parent, "root": entry.root}[linked]
    moved = tmp_path / f"moved-{linked}"
    place.rename(moved)
    place.symlink_to(moved)
    assert STORE.read(entry) is None


def test_a_body_of_another_shape_is_no_answer() -> None:
    entry = STORE.entry(["model"])
    STORE.write(entry, b'{"name": 3}')
    assert STORE.read(entry) is not None
    assert STORE.read_value(entry, CODEC, Answer) is None
    STORE.write(entry, b"not json")
    assert STORE.read_value(entry, CODEC, Answer) is None


def test_switched_off(monkeypatch: pytest.MonkeyPatch) -> None:
    assert STORE.enabled()
    monkeypatch.setenv(STORE.switch, "0")
    assert not STORE.enabled()


def test_reading_an_entry_marks_it_used_and_old_entries_go(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMIONNX_CACHE_MAX_DAYS", "1")
    read, stale = STORE.entry(["read"]), STORE.entry(["stale"])
    for entry in (read, stale):
        STORE.write_value(entry, CODEC, Answer(entry.key[:4], ()))
    old = time.time() - 3 * 86400
    for entry in (read, stale):
        os.utime(entry.file.parent, (old, old))
    assert STORE.read_value(read, CODEC, Answer) is not None  # used now
    STORE.write_value(STORE.entry(["new"]), CODEC, Answer("new", ()))
    assert not stale.file.parent.exists()
    assert read.file.exists()
    assert len(entries(STORE)) == 2


def test_an_unwritable_cache_is_no_error(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("")
    monkeypatch.setenv("FMIONNX_CACHE", str(blocked))
    entry = STORE.entry(["model"])
    STORE.write_value(entry, CODEC, Answer("a", ()))
    assert STORE.read_value(entry, CODEC, Answer) is None
