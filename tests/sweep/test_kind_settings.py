"""Settings a component's kind exposes as study targets: a signal's waveform numbers and a
MuJoCo scene's values. Each case's metric equals a direct run of a system file written with
the same value; bad names and values are reported at their place in the study file."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.core.types import PortRef
from tests.conftest import REPO, built_model

#: Dask's comms now and then leave a socket of a closed connection to the garbage collector.
pytestmark = pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")

#: A sine drives an integrator and a gain: ``final(gain.y)`` depends on the sine's numbers.
SINE_SYSTEM = """\
fmionnx: 1
name: sine_chain
run: {{stop: 0.4, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{y: {{sine: {{frequency: {frequency}, amplitude: {amplitude}}}}}}}}}
  integ: {{kind: fmu, path: models/Integrator.fmu}}
  gain: {{kind: fmu, path: models/Gain.fmu, parameters: {{k: 2, v: [0, 0, 0]}}}}
connections:
  - src.y -> integ.u
  - integ.x -> gain.u
"""

SINE_STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  src.amplitude: [0.5, 2]
  src.y.frequency: [1, 3]
metrics:
  y_end: final(gain.y)
  src_max: max(src.y)
"""

#: The reference scene's camera and sign detector, for a few frames: the blue sign (on the
#: robot's way at the start) seen at another place when the study moves it.
SCENE_SYSTEM = """\
fmionnx: 1
name: signs
run: {{stop: 0.2, step: 0.002}}
components:
  world:
    kind: mujoco
    path: {scene}
    cameras: {{front: {{width: 640, height: 480}}}}
  detector: {{kind: onnx, path: {detector}, period: 0.1, threads: 1}}
connections:
  - world.front -> detector.image
"""

SCENE_STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  world.body.sign_left.pos.y: [0, 0.6]
metrics:
  blue_x: final(detector.blobX[0,2])
  blue_size: final(detector.blobSize[0,2])
"""


def _sine_folder(folder: Path, fixture_fmu: Callable[[str], Path], **numbers: float) -> Path:
    models = folder / "models"
    models.mkdir(parents=True, exist_ok=True)
    for name in ("Integrator", "Gain"):
        shutil.copy(fixture_fmu(name), models / f"{name}.fmu")
    text = SINE_SYSTEM.format(**({"frequency": 1, "amplitude": 1} | numbers))
    (folder / "system.yaml").write_text(text, encoding="utf-8")
    return folder


def test_a_signals_numbers_vary_like_the_system_file(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], cluster: str
) -> None:
    folder = _sine_folder(tmp_path / "study", fixture_fmu)
    (folder / "study.yaml").write_text(SINE_STUDY, encoding="utf-8")
    table = fmionnx.sweep(folder / "study.yaml", out=tmp_path / "out", scheduler=cluster)

    assert (table["status"] == "ok").all(), table["message"].tolist()
    assert table[["src.amplitude", "src.y.frequency"]].to_numpy().tolist() == [
        [0.5, 1], [0.5, 3], [2, 1], [2, 3]
    ]  # fmt: skip
    assert len(set(table["y_end"])) == 4  # every setting changes the result
    for i, row in enumerate(table.to_dict("records")):
        direct = _sine_folder(
            tmp_path / f"direct-{i}",
            fixture_fmu,
            amplitude=row["src.amplitude"],
            frequency=row["src.y.frequency"],
        )
        refs = (PortRef("gain", "y"), PortRef("src", "y"))
        result = fmionnx.load(direct / "system.yaml").run(isolate="none", signals=refs)
        assert row["y_end"] == result["gain.y"][-1]
        assert row["src_max"] == max(result["src.y"])


def _scene_folder(folder: Path, sign_y: float | None = None) -> Path:
    """A system on a copy of the reference scene (its left sign moved to ``sign_y``)."""
    world = folder / "world"
    shutil.copytree(REPO / "models" / "world", world)
    scene = world / "sign_course.xml"
    if sign_y is not None:
        text = scene.read_text(encoding="utf-8")
        moved = text.replace(
            'name="sign_left" pos="4.8 0 0"', f'name="sign_left" pos="4.8 {sign_y} 0"'
        )
        assert moved != text
        scene.write_text(moved, encoding="utf-8")
    detector = built_model("sign_detector.onnx").resolve()
    text = SCENE_SYSTEM.format(scene="world/sign_course.xml", detector=detector.as_posix())
    (folder / "system.yaml").write_text(text, encoding="utf-8")
    return folder


def test_a_study_moves_a_sign_of_the_reference_scene(tmp_path: Path, cluster: str) -> None:
    folder = _scene_folder(tmp_path / "study")
    (folder / "study.yaml").write_text(SCENE_STUDY, encoding="utf-8")
    table = fmionnx.sweep(folder / "study.yaml", out=tmp_path / "out", scheduler=cluster)

    assert (table["status"] == "ok").all(), table["message"].tolist()
    first, moved = table.to_dict("records")
    assert first["blue_size"] > 0
    assert moved["blue_size"] > 0
    assert moved["blue_x"] != pytest.approx(first["blue_x"], abs=1e-3)  # ... elsewhere
    for row in (first, moved):
        direct = _scene_folder(
            tmp_path / f"direct-{row['case']}", row["world.body.sign_left.pos.y"]
        )
        refs = (PortRef("detector", "blobX"), PortRef("detector", "blobSize"))
        result = fmionnx.load(direct / "system.yaml").run(isolate="none", signals=refs)
        assert row["blue_x"] == pytest.approx(result["detector.blobX[0,2]"][-1])
        assert row["blue_size"] == pytest.approx(result["detector.blobSize[0,2]"][-1])


BAD_TARGETS = """\
fmionnx: 1
system: system.yaml
parameters:
  src.amplitud: [1]
  src.y.frequency: [1]
  world.body.sign_lft.pos: [[1, 2, 0]]
  world.body.base.pos: [[1, 2, 0]]
"""

BAD_VALUES = """\
fmionnx: 1
system: system.yaml
parameters:
  src.frequency: [1, -2]
  src.y.phase: ["a"]
  world.body.sign_left.pos: [[1, 2]]
  world.body.sign_stop.pos.x: {range: {start: 0, stop: 1, num: 2}}
"""


def _both_folder(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    folder = _sine_folder(tmp_path, fixture_fmu)
    text = (folder / "system.yaml").read_text(encoding="utf-8")
    scene = (REPO / "models" / "world" / "sign_course.xml").as_posix()
    text = text.replace("components:\n", f"components:\n  world: {{kind: mujoco, path: {scene}}}\n")
    (folder / "system.yaml").write_text(text, encoding="utf-8")
    return folder


def _sweep(study: Path, out: Path) -> tuple[int, list[str], list[str]]:
    result = CliRunner().invoke(
        app, ["sweep", str(study), "--out", str(out)], env={"COLUMNS": "200", "NO_COLOR": "1"}
    )
    lines = result.output.splitlines()
    errors = [line.split("/")[-1] for line in lines if ": error[" in line]
    hints = [line.strip() for line in lines if line.strip().startswith("hint:")]
    return result.exit_code, errors, hints


def test_unknown_settings_get_a_suggestion(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    folder = _both_folder(tmp_path / "s", fixture_fmu)
    (folder / "study.yaml").write_text(BAD_TARGETS, encoding="utf-8")
    code, errors, hints = _sweep(folder / "study.yaml", tmp_path / "out")
    assert code == 1
    assert errors == [
        "study.yaml:4:3: error[E107 study-setting]: `src.amplitud`: `src` has no parameter or "
        "setting `amplitud`",
        "study.yaml:6:3: error[E107 study-setting]: `world.body.sign_lft.pos`: `world` has no "
        "parameter or setting `body.sign_lft.pos`",
        "study.yaml:7:3: error[E107 study-setting]: `world.body.base.pos`: `world` has no "
        "parameter or setting `body.base.pos`",
    ]
    assert hints[:2] == [
        "hint: did you mean `amplitude`?",
        "hint: did you mean `body.sign_left.pos`?",
    ]
    assert hints[2] == (  # the robot moves: not a setting
        "hint: body `base` moves (a joint or mocap between it and the world): only bodies "
        "fixed to the world are scene values"
    )
    assert not (tmp_path / "out").exists()


def test_bad_values_are_refused_with_the_kinds_rules(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    folder = _both_folder(tmp_path / "s", fixture_fmu)
    (folder / "study.yaml").write_text(BAD_VALUES, encoding="utf-8")
    code, errors, _ = _sweep(folder / "study.yaml", tmp_path / "out")
    assert code == 1
    assert errors == [
        "study.yaml:4:18: error[E108 study-setting-value]: `src.frequency`: frequency -2: Input "
        "should be greater than or equal to 0",
        "study.yaml:5:16: error[E108 study-setting-value]: `src.y.phase`: `y.phase` takes a "
        "number, got `a`",
        "study.yaml:6:29: error[E108 study-setting-value]: `world.body.sign_left.pos`: "
        "`body.sign_left.pos` takes 3 numbers, got `[1, 2]`",
    ]
    assert not (tmp_path / "out").exists()


def test_settings_are_the_kinds_own(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> None:
    """The kinds list their settings; a new value is a new config, the base one unchanged."""
    from fmionnx.compile.studyir import apply_kind_setting
    from fmionnx.kinds.base import Settable, SettingError
    from fmionnx.kinds.registry import kind_of

    folder = _both_folder(tmp_path / "s", fixture_fmu)
    system = fmionnx.load(folder / "system.yaml").compiled
    src, world = system.component("src"), system.component("world")
    signal_kind, scene_kind = kind_of(src), kind_of(world)
    assert isinstance(signal_kind, Settable)
    assert isinstance(scene_kind, Settable)
    assert signal_kind.settings(src)[:4] == ("amplitude", "frequency", "phase", "offset")
    assert "y.amplitude" in signal_kind.settings(src)
    names = scene_kind.settings(world)
    assert {"body.sign_left.pos", "body.sign_stop.pos.z"} <= set(names)
    assert not any("base" in n or "wheel" in n for n in names)  # moving bodies are not offered

    changed = apply_kind_setting(system, "world.body.sign_stop.pos", (1.0, 2.0, 0.0))
    changed = apply_kind_setting(changed, "world.body.sign_stop.pos.x", 3)
    assert changed.component("world").config.scene_values == (  # type: ignore[attr-defined]
        ("body.sign_stop.pos", (1.0, 2.0, 0.0)),
        ("body.sign_stop.pos.x", (3.0,)),
    )
    assert system.component("world").config.scene_values == ()  # type: ignore[attr-defined]
    with pytest.raises(SettingError, match="finite"):
        apply_kind_setting(system, "world.body.sign_stop.pos.x", float("inf"))
    with pytest.raises(SettingError, match="duration"):  # not a ramp to a final value
        apply_kind_setting(system, "src.duration", 1.0)
