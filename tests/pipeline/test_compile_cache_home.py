"""The compile cache and model paths from a home folder: ``~/m.fmu`` names another model
under another ``HOME``, so a compile kept under one home is never read back under another."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

import fmionnx
from fmionnx.pipeline import compilecache
from fmionnx.pipeline.system import CompileResult, check_if_study, compile_system
from tests.conftest import build_fixture_fmu, let_files_settle
from tests.pipeline.test_compile_cache import resign

SYSTEM = """\
fmionnx: 1
name: s
run: {stop: 1, step: 0.1}
components: {g: {kind: fmu, path: ~/m.fmu}}
"""

STUDY = """\
fmionnx: 1
system: home.yaml
parameters: {run.stop: [0.5, 1]}
"""


@pytest.fixture
def homes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    """Two home folders, each with its own ``m.fmu`` (Gain, Scale3: other outputs), and a
    system naming ``~/m.fmu``, run from its folder; the cache folder fixed."""
    first, second = tmp_path / "h1", tmp_path / "h2"
    for home, model in ((first, "Gain"), (second, "Scale3")):
        home.mkdir()
        shutil.copy(build_fixture_fmu(model), home / "m.fmu")
    here = tmp_path / "system"
    here.mkdir()
    (here / "home.yaml").write_text(SYSTEM, encoding="utf-8")
    (here / "study.yaml").write_text(STUDY, encoding="utf-8")
    let_files_settle()
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(here)
    return first, second


def _columns(out: Path) -> str:
    return (out / "results.csv").read_text(encoding="utf-8").splitlines()[0]


def _compiled_under(home: Path, monkeypatch: pytest.MonkeyPatch) -> CompileResult:
    monkeypatch.setenv("HOME", str(home))
    return compile_system("home.yaml")


def test_another_home_runs_its_own_model(
    homes: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    first, second = homes
    for home, name in ((first, "first"), (second, "second"), (first, "again")):
        monkeypatch.setenv("HOME", str(home))
        fmionnx.run("home.yaml", out=Path(name), isolate="none")
    monkeypatch.setenv(compilecache.SWITCH, "0")
    monkeypatch.setenv("HOME", str(second))
    fmionnx.run("home.yaml", out=Path("off"), isolate="none")
    assert _columns(Path("second")) == _columns(Path("off"))
    assert _columns(Path("first")) != _columns(Path("second"))
    assert _columns(Path("again")) == _columns(Path("first"))  # each home keeps its entry


def test_a_compile_names_the_model_of_its_own_home(
    homes: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    first, second = homes
    compiled = [_compiled_under(home, monkeypatch) for home in (first, second)]
    paths = [[c.path for c in r.system.components] for r in compiled if r.system is not None]
    assert paths == [[first / "m.fmu"], [second / "m.fmu"]]


def test_a_study_of_a_system_with_home_paths_follows_home(
    homes: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The study's key has its own file's bytes, not its system file's: the home is in it."""
    for home in homes:
        monkeypatch.setenv("HOME", str(home))
        checked = check_if_study("study.yaml")
        assert checked is not None
        assert checked.system is not None
        assert [c.path for c in checked.system.components] == [home / "m.fmu"]


def test_an_entry_whose_home_path_names_another_model_is_not_used(
    homes: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """A home folder can move under a key that stays (``~user``: the user database is not
    in the key): the entry's model, still unchanged, is no longer the one the path names.
    Made here by putting the first home's sound entry under the second home's key."""
    first, second = homes
    _compiled_under(first, monkeypatch)
    root = tmp_path / "cache" / "compiled"
    (kept,) = (p for p in root.iterdir() if (p / compilecache.ENTRY).is_file())
    monkeypatch.setenv("HOME", str(second))
    place = compilecache.slot(Path("home.yaml"), None)
    assert place is not None
    assert place.key != kept.name
    shutil.copytree(kept, root / place.key)
    resign(root / place.key / compilecache.ENTRY, lambda data: data.update(key=place.key))
    assert compilecache.lookup(place) is None
    again = compile_system("home.yaml")
    assert again.system is not None
    assert [c.path for c in again.system.components] == [second / "m.fmu"]


def test_the_key_covers_the_folders_pythonpath_names(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A library found through ``PYTHONPATH`` (a ROS 2 install's) is part of the compiler."""
    library = tmp_path / "libraries"
    library.mkdir()
    os.utime(library, ns=(0, 0))  # a change below is a change of its time, however soon
    monkeypatch.setenv("PYTHONPATH", str(library))
    assert library in compilecache._library_folders()
    compilecache._code_stamp.cache_clear()
    before = compilecache._code_stamp()
    (library / "newer.dist-info").mkdir()
    compilecache._code_stamp.cache_clear()
    try:
        assert compilecache._code_stamp() != before
    finally:
        compilecache._code_stamp.cache_clear()


def test_the_working_folder_on_pythonpath_is_not_stamped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`PYTHONPATH=.` (a source checkout): the working folder's time changes with every file
    written there, which would make every compile a miss; the folder is in the key by name."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "src").mkdir()
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([".", "src", str(tmp_path)]))
    assert not [f for f in compilecache._library_folders() if f.is_relative_to(tmp_path)]
