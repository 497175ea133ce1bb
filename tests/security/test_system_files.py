"""Files fmionnx reads besides models: compiled systems and lock files stay in their place.

A compiled-system file (``*.fmionnx.json``) may come from another host, a lock file from a
pull request. Both are bounded, and neither can make fmionnx read or write elsewhere.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx import api
from fmionnx.cli.app import app
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.systemfile import (
    CompiledFileError,
    from_json,
    read_compiled,
    relocate,
    to_json,
    write_compiled,
)
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.lock.check import lock_system
from fmionnx.lock.model import lock_path
from fmionnx.lock.read import read_lock
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: small
run: {stop: 0.1, step: 0.01}
components:
  gain: {kind: fmu, path: Gain.fmu}
  integ: {kind: fmu, path: Integrator.fmu}
connections:
  - gain.y -> integ.u
"""


@pytest.fixture
def system(tmp_path: Path) -> Path:
    folder = tmp_path / "project"
    folder.mkdir()
    for name in ("Gain", "Integrator"):
        shutil.copy(build_fixture_fmu(name), folder / f"{name}.fmu")
    path = folder / "small.yaml"
    path.write_text(SYSTEM, encoding="utf-8")
    return path


def _compiled(system: Path) -> CompiledSystem:
    result = api.compile_system(system)
    assert result.system is not None, result.diagnostics
    return result.system


def test_a_compiled_system_larger_than_the_limit_is_refused_unread(
    system: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "small.fmionnx.json"
    write_compiled(_compiled(system), path)
    assert read_compiled(path).name == "small"
    monkeypatch.setenv("FMIONNX_MAX_COMPILED_BYTES", str(path.stat().st_size - 1))
    with pytest.raises(CompiledFileError, match="larger than") as info:
        read_compiled(path)
    assert "FMIONNX_MAX_COMPILED_BYTES" in str(info.value)


@pytest.mark.parametrize(
    "digest", ["../../outside", "/etc", "A" * 64], ids=["dotdot", "absolute", "not-hex"]
)
def test_a_model_store_path_from_a_compiled_file_stays_in_the_store(
    system: Path, tmp_path: Path, digest: str
) -> None:
    compiled = _compiled(system)
    component = compiled.components[0]
    forged = dataclasses.replace(
        component, interface=dataclasses.replace(component.interface, content_hash=digest)
    )
    store = tmp_path / "store"
    outside = store / digest / component.path.name
    outside.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(component.path, outside)  # what a forged hash would reach
    forged_system = dataclasses.replace(compiled, components=(forged, *compiled.components[1:]))
    with pytest.raises(CompiledFileError, match="does not name a file in a model store"):
        relocate(forged_system, store)


def test_a_lock_that_is_a_link_is_not_followed(system: Path, tmp_path: Path) -> None:
    locked = lock_system(system)
    assert locked.path is not None
    elsewhere = tmp_path / "elsewhere.lock"
    locked.path.rename(elsewhere)  # a valid lock, but not at its place
    lock_path(system).symlink_to(elsewhere)
    bag = DiagnosticBag()
    assert read_lock(lock_path(system), system, bag) is None
    (problem,) = list(bag)
    assert problem.code == "E082"
    assert "symbolic link" in problem.message


def test_a_lock_naming_its_system_by_a_path_is_e082(system: Path) -> None:
    locked = lock_system(system)
    assert locked.path is not None
    text = locked.path.read_text(encoding="utf-8")
    locked.path.write_text(text.replace("system: small.yaml", "system: ../../etc/passwd"))
    bag = DiagnosticBag()
    assert read_lock(locked.path, system, bag) is None
    (problem,) = list(bag)
    assert problem.code == "E082"
    assert problem.span is not None
    assert problem.span.line == 5


def test_model_paths_a_lock_names_are_never_opened(system: Path, tmp_path: Path) -> None:
    """A lock naming a FIFO as a model: opening it would block forever (the deadline fails)."""
    fifo = tmp_path / "trap.fmu"
    os.mkfifo(fifo)
    locked = lock_system(system)
    assert locked.path is not None
    text = locked.path.read_text(encoding="utf-8")
    locked.path.write_text(text.replace("path: Gain.fmu", f'path: "{fifo}"'))
    result = CliRunner().invoke(app, ["validate", "--locked", str(system)])
    assert result.exit_code == 0, result.output


def test_a_compiled_file_declaring_a_huge_port_is_refused(system: Path) -> None:
    """Port shapes are not part of the content hash: an edited file must still be bounded."""
    document = json.loads(to_json(_compiled(system)))
    port = document["system"]["components"][1]["interface"]["ports"][0]
    port["shape"] = [1_000_000, 1_000_000]
    with pytest.raises(CompiledFileError, match=f"port `{port['name']}` of shape") as info:
        from_json(json.dumps(document))
    assert "FMIONNX_MAX_ARRAY_ELEMENTS" in str(info.value)


def _damaged(system: Path, tmp_path: Path, damage: str) -> Path:
    """The compiled system of ``system``, written and then damaged as ``damage`` says."""
    path = tmp_path / "small.fmionnx.json"
    write_compiled(_compiled(system), path)
    document = json.loads(path.read_text(encoding="utf-8"))
    if damage == "hash":
        document["content_hash"] = "0" * 64
    elif damage == "nan-step":
        document["system"]["run"]["step"] = float("nan")
    elif damage == "huge-port":
        document["system"]["components"][1]["interface"]["ports"][0]["shape"] = [10**6, 10**6]
    elif damage == "not-an-object":
        document["system"] = None
    path.write_text(json.dumps(document), encoding="utf-8")
    return path


@pytest.mark.parametrize("damage", ["hash", "nan-step", "huge-port", "not-an-object"])
@pytest.mark.parametrize("command", [["run", "--no-out"], ["node", "COMPONENT"]])
def test_run_and_node_refuse_a_damaged_compiled_system_in_one_line(
    system: Path, tmp_path: Path, damage: str, command: list[str]
) -> None:
    """``run`` reports a refused compiled-system file as ``node`` does: exit 1, one line
    naming the file, no traceback (issue #38: ``run`` raised CompiledFileError)."""
    path = _damaged(system, tmp_path, damage)
    args = [command[0], str(path), *(["gain"] if command[0] == "node" else command[1:])]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 1, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    assert lines[0].startswith("error: ")
    assert str(path) in " ".join(result.output.split())
