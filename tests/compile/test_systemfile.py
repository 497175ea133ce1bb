"""The compiled system as a file: it reads back equal, refuses damage, finds models by hash."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import fmionnx
from fmionnx import api
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.systemfile import (
    CompiledFileError,
    from_json,
    place_models,
    read_compiled,
    relocate,
    stored_model,
    to_json,
    write_compiled,
)
from fmionnx.core.modelfiles import ShippingError
from fmionnx.runtime.master import Master
from fmionnx.runtime.result import RunOptions

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "systems" / "sign_follower.yaml"


def _compiled(path: Path = REFERENCE) -> CompiledSystem:
    result = api.compile_system(path)
    assert result.system is not None, [str(d) for d in result.diagnostics]
    return result.system


@pytest.fixture(scope="module")
def reference() -> CompiledSystem:
    return _compiled()


def test_the_reference_system_reads_back_equal(reference: CompiledSystem) -> None:
    text = to_json(reference)
    back = from_json(text)
    assert back == reference
    assert back.content_hash == reference.content_hash
    assert back.ros2_plan is not None
    assert back.ros2_plan == reference.ros2_plan
    assert to_json(back) == text  # stable: a second write gives the same bytes


def test_the_file_names_its_format_version_and_every_model_hash(reference: CompiledSystem) -> None:
    document = json.loads(to_json(reference))
    assert document["format"] == "fmionnx-compiled-system"
    assert document["version"] == 2
    assert document["content_hash"] == reference.content_hash
    assert document["models"] == {c.name: c.interface.content_hash for c in reference.components}
    configs = {c["name"]: c["config"]["kind"] for c in document["system"]["components"]}
    assert configs == {c.name: c.kind for c in reference.components}


def test_the_file_holds_no_front_end_type(reference: CompiledSystem) -> None:
    """Every value is plain JSON made from the IR's own dataclasses (no pydantic dump)."""
    text = to_json(reference)
    assert "model_config" not in text
    assert "Spec" not in text


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.update(version=99), "version 99"),
        (lambda d: d.update(format="x"), "not a compiled-system file"),
        (lambda d: d["system"].update(name="other"), "does not match its content hash"),
        (lambda d: d["system"]["run"].update(step="fast"), "system.run.step: expected a number"),
        (
            lambda d: d["system"]["run"].update(speed=2),
            "system.run.speed: unknown field of RunSettings",
        ),
        (
            lambda d: d["system"]["components"][0]["config"].update(kind="nope"),
            "system.components[0].config.kind",
        ),
    ],
)
def test_a_damaged_file_is_refused_with_where(
    reference: CompiledSystem, change: object, message: str
) -> None:
    document = json.loads(to_json(reference))
    change(document)  # type: ignore[operator]
    with pytest.raises(CompiledFileError, match=message.replace("[", r"\[").replace("]", r"\]")):
        from_json(json.dumps(document))


def test_not_json_is_refused() -> None:
    with pytest.raises(CompiledFileError, match="invalid JSON"):
        from_json("{")
    with pytest.raises(CompiledFileError, match="nested too deeply"):
        from_json("[" * 100_000 + "]" * 100_000)


def test_models_placed_by_hash_run_to_the_same_results(
    reference: CompiledSystem, tmp_path: Path
) -> None:
    """An empty folder with the file and a model store runs as the original does."""
    store = tmp_path / "models"
    placed = place_models(reference, store)
    assert {p.parent.name for p in placed} == {
        c.interface.content_hash for c in reference.components
    }
    write_compiled(reference, tmp_path / "system.fmionnx.json")
    moved = read_compiled(tmp_path / "system.fmionnx.json", models=store)
    assert all(c.path.is_relative_to(store) for c in moved.components)
    short = dataclasses.replace(reference, run=dataclasses.replace(reference.run, stop=0.3))
    moved_short = dataclasses.replace(moved, run=short.run)
    ours = Master(short, RunOptions()).run()
    theirs = Master(moved_short, RunOptions()).run()
    assert ours.status.value == theirs.status.value == "completed"
    assert ours.signals.keys() == theirs.signals.keys()
    for name, values in ours.signals.items():
        assert np.array_equal(values, theirs.signals[name], equal_nan=True), name


def test_a_missing_or_changed_model_is_refused(reference: CompiledSystem, tmp_path: Path) -> None:
    store = tmp_path / "models"
    with pytest.raises(CompiledFileError, match="is not in"):
        relocate(reference, store)
    place_models(reference, store)
    odometry = reference.component("odometry")
    target = stored_model(store, odometry)
    target.unlink()
    other = reference.component("tracker").path
    shutil.copy(other, target)
    with pytest.raises(CompiledFileError, match="does not match the compiled system"):
        relocate(reference, store)
    # Compiling again into that store says so at once, and replaces nothing (a bug hunt:
    # it listed the wrong file as placed, and every node refused it later).
    with pytest.raises(ShippingError, match=r"does not match the compiled system.*move it out"):
        place_models(reference, store)
    assert target.read_bytes() == other.read_bytes()


def test_a_system_file_still_loads_as_before() -> None:
    assert fmionnx.load(REFERENCE).compiled.name == "sign_follower"


def test_signal_components_travel_in_the_file_and_need_no_model(tmp_path: Path) -> None:
    """Waveforms are the signal kind's config: a ramp to a final value stays a ramp-to."""
    system = _compiled(REPO / "systems" / "open_loop.yaml")
    back = from_json(to_json(system))
    assert back == system
    command = back.component("command")
    assert type(command.config).__name__ == "SignalConfig"
    kinds = {name: type(w).__name__ for name, w in command.config.outputs}  # type: ignore[attr-defined]
    assert kinds == {"v": "RampTo", "w": "Sine"}
    store = tmp_path / "models"
    placed = place_models(system, store)
    assert len(placed) == len(system.components) - 1  # nothing to place for the signal
    moved = relocate(back, store)
    short = dataclasses.replace(moved, run=dataclasses.replace(moved.run, stop=0.5))
    ours = Master(dataclasses.replace(system, run=short.run), RunOptions()).run()
    theirs = Master(short, RunOptions()).run()
    for name, values in ours.signals.items():
        assert np.array_equal(values, theirs.signals[name]), name


@pytest.mark.parametrize(
    ("start", "stop", "step", "message"),
    [
        (0.0, 1.0, 5e-324, "subnormal"),
        (-1e308, 1e308, 0.01, "longer than the largest float"),
        (0.0, 1e300, 1e-300, "2\\*\\*53"),
        (1.0, 1.0, 0.01, "stop is not after start"),
    ],
)
def test_a_consistent_file_with_run_settings_out_of_range_is_refused(
    reference: CompiledSystem, start: float, stop: float, step: float, message: str
) -> None:
    from fmionnx.compile.ir import RunSettings

    bad = dataclasses.replace(reference, run=RunSettings(start, stop, step, reference.run.origins))
    with pytest.raises(CompiledFileError, match=message):
        from_json(to_json(bad))  # the content hash matches: only the range check refuses it


def test_a_consistent_file_with_a_period_beyond_2_53_steps_is_refused(
    reference: CompiledSystem,
) -> None:
    first = dataclasses.replace(reference.components[0], period_steps=2**60)
    bad = dataclasses.replace(reference, components=(first, *reference.components[1:]))
    with pytest.raises(CompiledFileError, match="period_steps out of range"):
        from_json(to_json(bad))


def test_a_compiled_file_finds_its_models_from_any_folder_and_says_when_one_is_gone(
    tmp_path: Path, fixture_fmu, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A bug hunt: model paths were kept relative to the folder `compile` ran in, so the file
    run from its own folder (or moved) ended in a fault "models/G.fmu does not exist" after
    a results folder was made. They are absolute now, and a missing one is refused on
    reading, with its name."""
    project = tmp_path / "proj"
    (project / "models").mkdir(parents=True)
    shutil.copy(fixture_fmu("Gain"), project / "models" / "G.fmu")
    (project / "sys.yaml").write_text(
        "fmionnx: 1\nname: p\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        "  gain: {kind: fmu, path: models/G.fmu, parameters: {k: 3, u: 1}}\n",
        encoding="utf-8",
    )
    monkeypatch.chdir(project)
    compiled = tmp_path / "dist" / "p.fmionnx.json"
    compiled.parent.mkdir()
    write_compiled(fmionnx.load("sys.yaml").compiled, compiled)
    monkeypatch.chdir(compiled.parent)
    system = read_compiled(Path(compiled.name))
    (gain,) = system.components
    assert gain.path == project / "models" / "G.fmu"
    assert gain.interface.path == gain.path
    assert Master(system, RunOptions()).run().signals["gain.y"][-1] == 3.0
    (project / "models" / "G.fmu").rename(project / "models" / "moved.fmu")
    with pytest.raises(CompiledFileError, match=r"component `gain`: its model `.*G\.fmu` does not"):
        read_compiled(Path(compiled.name))


def _edited(system: CompiledSystem, edit) -> str:  # type: ignore[no-untyped-def]
    document = json.loads(to_json(system))
    edit(document["system"])
    return json.dumps(document)


def _gain_port(system: dict, name: str) -> dict:  # type: ignore[type-arg]
    (component,) = [c for c in system["components"] if c["name"] == "gain"]
    (port,) = [p for p in component["interface"]["ports"] if p["name"] == name]
    return port  # type: ignore[no-any-return]


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (
            lambda s: s.update(record=[{"component": "nope", "port": "zz", "index": None}]),
            "`record` names `nope.zz`, which no component of the system has: damaged",
        ),
        (
            lambda s: _gain_port(s, "y").update(vrs=[]),
            "component `gain`: port `y` has value references [] for shape []: damaged",
        ),
        (
            lambda s: _gain_port(s, "y").update(vrs=[2**70]),
            "component `gain`: port `y` has value references",
        ),
        (
            lambda s: _gain_port(s, "w").update(shape=[2]),
            "component `gain`: port `w` has value references [6, 7, 8] for shape [2]",
        ),
    ],
)
def test_an_edit_the_content_hash_does_not_cover_is_refused(
    tmp_path: Path, fixture_fmu, edit, expected: str
) -> None:  # type: ignore[no-untyped-def]
    """A bug hunt: the interfaces and `record` are outside the content hash (a model is
    named by its file's hash); an edited record ended in a KeyError traceback, edited value
    references ran silently reading another variable (or none), an edited shape dropped
    columns. Each is refused on reading, one line."""
    system_file = tmp_path / "g.yaml"
    system_file.write_text(
        f"fmionnx: 1\nname: g\nrun: {{stop: 0.1, step: 0.01}}\ncomponents:\n"
        f"  gain: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n",
        encoding="utf-8",
    )
    text = _edited(fmionnx.load(system_file).compiled, edit)
    with pytest.raises(CompiledFileError) as refused:
        from_json(text, origin="g.fmionnx.json")
    assert expected in str(refused.value)
    assert str(refused.value).startswith("g.fmionnx.json: ")


@pytest.mark.parametrize("part", ["plots", "checks"])
def test_a_plot_or_check_naming_no_port_is_refused_on_reading(
    tmp_path: Path, fixture_fmu, part: str
) -> None:  # type: ignore[no-untyped-def]
    """Plots and checks name the ports they read (recorded whatever `record` says): one
    naming no port was a KeyError where the run recorded it."""
    system_file = tmp_path / "g.yaml"
    system_file.write_text(
        f"fmionnx: 1\nname: g\nrun: {{stop: 0.1, step: 0.01}}\ncomponents:\n"
        f"  gain: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "plots: [{y: [gain.y], file: y.png}]\n"
        "checks: [{name: high, expect: max(gain.y) < 10}]\n",
        encoding="utf-8",
    )
    bogus = {"component": "gain", "port": "nope", "index": None}

    def edit(system: dict) -> None:  # type: ignore[type-arg]
        system[part][0]["refs"] = [bogus]

    text = _edited(fmionnx.load(system_file).compiled, edit)
    with pytest.raises(CompiledFileError) as refused:
        from_json(text, origin="g.fmionnx.json")
    what = "plot `y.png`" if part == "plots" else "check `high`"
    assert f"{what} names `gain.nope`, which no component of the system has" in str(refused.value)
