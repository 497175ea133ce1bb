"""The OpenGL probe's answer is kept for a day, per machine and environment (issue #32)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from fmionnx.kinds.mujoco import gl, glcache


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A cache folder of the test's own, and no answer of this process's yet."""
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path))
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.delenv(glcache.SWITCH, raising=False)
    monkeypatch.setattr(gl, "_probed", {})
    monkeypatch.setattr(gl, "_chosen", None)
    return tmp_path / "gl"


def _probes(monkeypatch: pytest.MonkeyPatch, works: set[str]) -> list[str]:
    """Stand in for the probe's child process (a peer here): which backends it tried."""
    tried: list[str] = []

    def works_here(backend: str) -> bool:
        tried.append(backend)
        return backend in works

    monkeypatch.setattr(gl, "_works", works_here)
    return tried


def test_a_real_probe_is_kept_and_the_next_process_does_not_probe(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    found = gl.backend_for("auto")  # the real child process: MuJoCo renders one frame
    assert found in {"egl", "osmesa"}
    assert [p.read_text("ascii").strip() for p in cache.iterdir()] == [found]
    monkeypatch.setattr(gl, "_probed", {})  # as a new process would start
    tried = _probes(monkeypatch, works=set())
    assert gl.backend_for("auto") == found
    assert tried == []


def test_what_decides_the_backend_is_in_the_key(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    tried = _probes(monkeypatch, works={"osmesa"})
    monkeypatch.setenv("DISPLAY", ":0")
    assert gl.backend_for("auto") == "osmesa"
    assert tried == ["egl", "osmesa"]
    monkeypatch.setattr(gl, "_probed", {})
    monkeypatch.setenv("DISPLAY", ":1")  # another display: asked again
    assert gl.backend_for("auto") == "osmesa"
    assert tried == ["egl", "osmesa", "egl", "osmesa"]
    assert len(list(cache.iterdir())) == 2


def test_the_library_path_counts_as_a_set_of_folders(monkeypatch: pytest.MonkeyPatch) -> None:
    """The ROS 2 wheels' start-up writes the same folders in another order in each process."""
    monkeypatch.setenv("LD_LIBRARY_PATH", "/a:/b")
    first = glcache.entry("auto")
    monkeypatch.setenv("LD_LIBRARY_PATH", "/b:/a")
    assert glcache.entry("auto") == first
    monkeypatch.setenv("LD_LIBRARY_PATH", "/b:/c")
    assert glcache.entry("auto") != first


def test_nothing_is_kept_when_no_backend_works(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _probes(monkeypatch, works=set())
    assert gl.backend_for("auto") is None
    assert not cache.exists()
    with pytest.raises(RuntimeError, match="no offscreen OpenGL backend works"):
        gl.choose_gl("auto")


def test_an_old_or_damaged_answer_is_not_trusted(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    glcache.remember("auto", "osmesa")
    path = glcache.entry("auto")
    old = time.time() - glcache.MAX_AGE - 60
    os.utime(path, (old, old))
    assert glcache.recall("auto") is None
    path.write_text("egl; rm -rf /\n", "ascii")
    assert glcache.recall("auto") is None
    path.write_text("\xff\xfe", "latin-1")
    assert glcache.recall("auto") is None


def test_old_entries_go_when_an_answer_is_kept(cache: Path) -> None:
    cache.mkdir(parents=True)
    stale = cache / "0123.txt"
    stale.write_text("egl\n", "ascii")
    old = time.time() - glcache.MAX_AGE - 60
    os.utime(stale, (old, old))
    glcache.remember("auto", "egl")
    assert [p.name for p in cache.iterdir()] == [glcache.entry("auto").name]


def test_a_failed_renderer_drops_the_kept_answer(cache: Path) -> None:
    glcache.remember("auto", "egl")
    assert glcache.recall("auto") == "egl"
    gl.forget_probe("auto")
    assert glcache.recall("auto") is None


def test_keeping_can_be_turned_off(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(glcache.SWITCH, "0")
    tried = _probes(monkeypatch, works={"egl"})
    assert gl.backend_for("auto") == "egl"
    assert not cache.exists()
    monkeypatch.setattr(gl, "_probed", {})
    assert gl.backend_for("auto") == "egl"
    assert tried == ["egl", "egl"]


def test_an_unwritable_cache_is_no_error(cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text("a file where the folder would be", "ascii")
    _probes(monkeypatch, works={"egl"})
    assert gl.backend_for("auto") == "egl"
    assert glcache.recall("auto") is None
