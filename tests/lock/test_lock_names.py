"""Lock names: `X.yaml`, `X.yml` and `X.ssp` share `X.fmionnx.lock`; the lock's `system:` says
whose it is. Locking one never replaces another's lock without --force, checking one against
another's lock says so (E081) instead of diffing models the system does not use, several
systems are all compiled before any lock is written, and `.`, `/` and "" end in one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.lock.model import lock_path
from tests.conftest import cli

HEADER = "fmionnx: 1\nname: {name}\nrun: {{stop: 1, step: 0.1}}\ncomponents:\n"


def _system(path: Path, output: str = "a") -> Path:
    """A system of one signal component with the one output ``output``."""
    text = HEADER.format(name=path.stem) + "  s:\n    kind: signal\n    outputs:\n"
    path.write_text(text + f"      {output}: {{constant: 1}}\n", encoding="utf-8")
    return path


def _bad(path: Path) -> Path:
    path.write_text(HEADER.format(name="bad") + "  s: {kind: nothing}\n", encoding="utf-8")
    return path


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def test_locking_the_yml_twin_does_not_replace_the_yaml_lock(folder: Path) -> None:
    _system(folder / "good.yaml", "a")
    _system(folder / "good.yml", "b")
    assert cli("lock", "good.yaml")[0] == 0
    before = (folder / "good.fmionnx.lock").read_text(encoding="utf-8")
    code, output = cli("lock", "good.yml")
    assert code == 2
    assert "`good.fmionnx.lock` is the lock of `good.yaml`, not of `good.yml`" in output
    assert "--force" in output
    assert (folder / "good.fmionnx.lock").read_text(encoding="utf-8") == before
    assert cli("lock", "--force", "good.yml")[0] == 0
    assert "system: good.yml" in (folder / "good.fmionnx.lock").read_text(encoding="utf-8")


def test_validating_against_another_systems_lock_says_whose_it_is(folder: Path) -> None:
    _system(folder / "good.yaml", "a")
    _system(folder / "good.yml", "b")
    assert cli("lock", "good.yml")[0] == 0
    code, output = cli("validate", "--locked", "good.yaml")
    assert code == 1
    assert (
        "good.yaml: error[E081 lock-missing]: `good.fmionnx.lock` is the lock of `good.yml`, "
        "not of `good.yaml`" in output
    )
    assert "note: good.fmionnx.lock:5:9: the system this lock belongs to" in output
    assert "E080" not in output  # no diff against a model good.yaml does not use
    assert cli("validate", "--locked", "good.yml")[0] == 0


def test_an_ssp_converted_to_yaml_is_not_checked_against_the_ssps_lock(folder: Path) -> None:
    _system(folder / "X.yaml")
    assert cli("export", "X.yaml", "-o", "X.ssp")[0] == 0
    (folder / "X.yaml").unlink()
    assert cli("lock", "X.ssp")[0] == 0
    assert cli("convert", "X.ssp", "-o", "X.yaml")[0] == 0
    code, output = cli("validate", "--locked", "X.yaml")
    assert code == 1
    assert "`X.fmionnx.lock` is the lock of `X.ssp`, not of `X.yaml`" in output
    assert cli("lock", "X.yaml")[0] == 2
    assert cli("lock", "--force", "X.yaml")[0] == 0
    assert cli("validate", "--locked", "X.yaml")[0] == 0


def test_two_systems_sharing_a_lock_name_are_refused_together(folder: Path) -> None:
    _system(folder / "good.yaml", "a")
    _system(folder / "good.yml", "b")
    code, output = cli("lock", "good.yaml", "good.yml")
    assert code == 2
    assert "`good.yaml` and `good.yml` share the lock name `good.fmionnx.lock`" in output
    assert not (folder / "good.fmionnx.lock").exists()


def test_one_system_named_twice_is_locked_once(folder: Path) -> None:
    _system(folder / "good.yaml")
    code, output = cli("lock", "good.yaml", "./good.yaml")
    assert code == 0, output
    assert output == "wrote good.fmionnx.lock"


def test_every_system_is_compiled_before_any_lock_is_written(folder: Path) -> None:
    _system(folder / "good.yaml")
    _bad(folder / "bad.yaml")
    code, output = cli("lock", "good.yaml", "bad.yaml")
    assert code == 1
    assert "bad.yaml" in output
    assert "not locked: fix the errors above first (no lock was written)" in output
    assert not (folder / "good.fmionnx.lock").exists()
    assert not (folder / "bad.fmionnx.lock").exists()
    code, output = cli("lock", "bad.yaml", "good.yaml")  # the order does not matter
    assert code == 1
    assert not (folder / "good.fmionnx.lock").exists()


def test_a_refused_lock_name_leaves_every_lock_as_it_was(folder: Path) -> None:
    _system(folder / "good.yaml")
    _system(folder / "other.yaml")
    (folder / "other.fmionnx.lock").write_text("my notes\n", encoding="utf-8")
    code, output = cli("lock", "good.yaml", "other.yaml")
    assert code == 2
    assert "not written by `fmionnx lock`" in output
    assert not (folder / "good.fmionnx.lock").exists()


@pytest.mark.parametrize("name", [".", "/", "", ".."])
def test_a_folder_is_no_system_to_lock(folder: Path, name: str) -> None:
    (folder / "sub").mkdir()
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(folder / "sub")
        code, output = cli("lock", name)
        assert code == 1
        assert "E011" in output
        assert "is a folder, not a system file" in output
        code, output = cli("validate", "--locked", name)
        assert code == 1
        assert "E011" in output
    assert not list(folder.rglob("*.fmionnx.lock"))


def test_lock_path_of_a_nameless_path_is_the_folders_or_a_clear_error(folder: Path) -> None:
    assert lock_path(Path("robot.ssp")) == Path("robot.fmionnx.lock")
    assert lock_path(Path()) == folder.parent / f"{folder.name}.fmionnx.lock"
    with pytest.raises(ValueError, match="is a folder, not a system file"):
        lock_path(Path("/"))
