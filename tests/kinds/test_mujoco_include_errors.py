"""A MuJoCo scene naming a file that is not there (an ``<include>``, an attached ``<model>``) is
E010 naming that file and where it is named, never "the scene cannot be read" about a scene
that exists; ``validate``, ``run`` and ``inspect`` say the same, with the code."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import cli

SYSTEM = "fmionnx: 1\nname: mjs\nrun: {stop: 0.01, step: 0.002}\ncomponents:\n"


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    (tmp_path / "inc.xml").write_text(
        '<mujoco>\n  <include file="missing.xml"/>\n</mujoco>\n', encoding="utf-8"
    )
    (tmp_path / "sys.yaml").write_text(
        SYSTEM + "  w: {kind: mujoco, path: inc.xml}\n", encoding="utf-8"
    )
    return tmp_path


MISSING = (
    "`inc.xml`: the included file `missing.xml` at `inc.xml:2` cannot be read: "
    "No such file or directory"
)


def test_validate_names_the_missing_include_not_the_scene(folder: Path) -> None:
    code, output = cli("validate", "sys.yaml")
    assert code == 1
    assert f"error[E010 file-not-found]: component `w`: {MISSING}" in output
    assert "`inc.xml` cannot be read" not in output


def test_validating_the_scene_alone_says_the_same(folder: Path) -> None:
    code, output = cli("validate", "inc.xml")
    assert code == 1
    assert f"inc.xml: error[E010 file-not-found]: {MISSING}" in output


def test_run_says_the_same(folder: Path) -> None:
    code, output = cli("run", "sys.yaml", "--out", str(folder / "out"))
    assert code == 1
    assert MISSING in output


def test_inspect_says_the_same_with_the_code(folder: Path) -> None:
    code, output = cli("inspect", "inc.xml")
    assert code == 1
    assert f"error[E010]: {MISSING}" in output


def test_a_missing_file_of_a_nested_include_names_the_file_that_includes_it(
    folder: Path,
) -> None:
    (folder / "a.xml").write_text('<mujoco>\n<include file="b.xml"/>\n</mujoco>\n', "utf-8")
    (folder / "b.xml").write_text(
        '<mujoco>\n<worldbody><geom size="1"/></worldbody>\n<include file="sub/gone.xml"/>\n'
        "</mujoco>\n",
        "utf-8",
    )
    code, output = cli("validate", "a.xml")
    assert code == 1
    assert (
        "error[E010 file-not-found]: `a.xml`: the included file `sub/gone.xml` at `b.xml:3` "
        "cannot be read: No such file or directory" in output
    )


def test_a_missing_attached_model_is_named(folder: Path) -> None:
    (folder / "att.xml").write_text(
        '<mujoco>\n<asset><model name="arm" file="gone.xml"/></asset>\n'
        '<worldbody><body name="b"><attach model="arm" prefix="a_"/></body></worldbody>\n'
        "</mujoco>\n",
        "utf-8",
    )
    code, output = cli("validate", "att.xml")
    assert code == 1
    assert "error[E010 file-not-found]: `att.xml`: the model file `gone.xml` at `att.xml:2`" in (
        output
    )


def test_an_oserror_about_another_file_names_that_file(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Whatever a kind lets through about a file the model needs, the model is not blamed."""
    from fmionnx.kinds.mujoco import interface

    def missing(path: Path) -> None:
        raise FileNotFoundError(2, "No such file or directory", str(folder / "mesh.stl"))

    monkeypatch.setattr(interface, "check_scene_before_loading", missing)
    (folder / "inc.xml").write_text("<mujoco/>\n", encoding="utf-8")
    code, output = cli("validate", "sys.yaml")
    assert code == 1
    assert (
        f"component `w`: `{folder / 'mesh.stl'}` (a file `inc.xml` needs) cannot be read: "
        "No such file or directory" in output
    )


def test_an_oserror_about_the_model_itself_names_the_model(
    folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from fmionnx.kinds.mujoco import interface

    def unreadable(path: Path) -> None:
        raise PermissionError(13, "Permission denied", str(path.absolute()))

    monkeypatch.setattr(interface, "check_scene_before_loading", unreadable)
    (folder / "inc.xml").write_text("<mujoco/>\n", encoding="utf-8")
    code, output = cli("validate", "sys.yaml")
    assert code == 1
    assert "component `w`: `inc.xml` cannot be read: Permission denied" in output
