"""The kinds' settings (:class:`fmionnx.kinds.base.Settable`): a signal's waveform numbers,
checked like its system-file entry, and a MuJoCo scene's values, applied by the runner to the
loaded model before the first step."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

import fmionnx
from fmionnx.compile.studyir import apply_kind_setting
from fmionnx.core.types import PortRef
from fmionnx.kinds.base import Settable, SettingError
from fmionnx.kinds.registry import kind_of, make_runner

SIGNALS = """\
fmionnx: 1
name: waves
run: {stop: 1, step: 0.1}
components:
  src:
    kind: signal
    outputs:
      c: {constant: 2}
      s: {step: {time: 0.5}}
      r: {ramp: {slope: 1}}
      rt: {ramp: {final: 1, duration: 2}}
      sn: {sine: {frequency: 1}}
"""

SCENE = """\
<mujoco>
  <custom><numeric name="gains" data="1 2"/></custom>
  <worldbody>
    <body name="post" pos="1 0 0">
      <site name="tip" pos="0 0 0.5"/>
      <body name="cap" pos="0 0 1"/>
    </body>
    <body name="ball" pos="0 0 1">
      <freejoint/>
      <geom type="sphere" size="0.1"/>
    </body>
  </worldbody>
</mujoco>
"""

SCENE_SYSTEM = """\
fmionnx: 1
name: scene
run: {stop: 0.01, step: 0.002}
components:
  world: {kind: mujoco, path: scene.xml}
"""


@pytest.fixture
def signals(tmp_path: Path) -> fmionnx.System:
    (tmp_path / "system.yaml").write_text(SIGNALS, encoding="utf-8")
    return fmionnx.load(tmp_path / "system.yaml")


@pytest.fixture
def scene(tmp_path: Path) -> fmionnx.System:
    (tmp_path / "scene.xml").write_text(SCENE, encoding="utf-8")
    (tmp_path / "system.yaml").write_text(SCENE_SYSTEM, encoding="utf-8")
    return fmionnx.load(tmp_path / "system.yaml")


def test_every_waveform_number_is_a_setting(signals: fmionnx.System) -> None:
    src = signals.compiled.component("src")
    kind = kind_of(src)
    assert isinstance(kind, Settable)
    assert kind.settings(src) == (
        "c.value",
        "s.time", "s.initial", "s.final",
        "r.time", "r.initial", "r.slope",
        "rt.time", "rt.initial", "rt.final", "rt.duration",
        "sn.amplitude", "sn.frequency", "sn.phase", "sn.offset",
    )  # fmt: skip


@pytest.mark.parametrize(
    ("target", "value", "port", "expected"),
    [
        ("src.c.value", 5, "src.c", 5.0),
        ("src.s.final", 3, "src.s", 3.0),
        ("src.r.slope", -2, "src.r", -2.0),
        ("src.rt.duration", 0.5, "src.rt", 1.0),
        ("src.sn.offset", 4, "src.sn", 4.0),
    ],
)
def test_a_new_number_changes_the_run(
    signals: fmionnx.System, target: str, value: float, port: str, expected: float
) -> None:
    changed = apply_kind_setting(signals.compiled, target, value)
    record = (PortRef(*port.split(".")),)
    result = dataclasses.replace(signals, compiled=changed).run(isolate="none", signals=record)
    assert result[port][-1] == pytest.approx(expected)
    base = signals.run(isolate="none", signals=record)
    assert base[port][-1] != pytest.approx(expected)  # the base system is unchanged


@pytest.mark.parametrize(
    ("target", "value", "message"),
    [
        ("src.sn.frequency", -1, "greater than or equal to 0"),
        ("src.sn.frequency", 2e12, "less than or equal to 1000000000000"),
        ("src.rt.duration", 0, "greater than 0"),
        ("src.c.value", float("nan"), "finite number"),
        ("src.c.value", True, "takes a number"),
        ("src.c.value", (1, 2), "takes a number"),
        ("src.amplitude", 1, "did you mean `sn.amplitude`"),  # several outputs: no bare keys
    ],
)
def test_refused_numbers_say_why(
    signals: fmionnx.System, target: str, value: object, message: str
) -> None:
    with pytest.raises(SettingError, match=re.escape(message)):
        apply_kind_setting(signals.compiled, target, value)  # type: ignore[arg-type]


def test_a_scene_offers_its_fixed_bodies_and_numeric_fields(scene: fmionnx.System) -> None:
    world = scene.compiled.component("world")
    kind = kind_of(world)
    assert isinstance(kind, Settable)
    names = kind.settings(world)
    assert "numeric.gains" in names
    assert {"body.post.pos", "body.post.pos.z", "body.cap.pos.x"} <= set(names)
    assert not any("ball" in n for n in names)  # a free body moves: not a setting
    with pytest.raises(SettingError, match="2 numbers"):
        apply_kind_setting(scene.compiled, "world.numeric.gains", 1.0)
    with pytest.raises(SettingError, match=re.escape("did you mean `body.post.pos`")):
        apply_kind_setting(scene.compiled, "world.body.pst.pos", (0, 0, 0))
    with pytest.raises(SettingError, match=re.escape("body `ball` moves")):
        apply_kind_setting(scene.compiled, "world.body.ball.pos.x", 1)


def test_a_tables_values_are_not_settings(tmp_path: Path) -> None:
    (tmp_path / "t.csv").write_text("time,v\n0,1\n1,2\n", encoding="utf-8")
    text = "fmionnx: 1\nname: t\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
    text += "  tab: {kind: signal, path: t.csv}\n"
    (tmp_path / "system.yaml").write_text(text, encoding="utf-8")
    system = fmionnx.load(tmp_path / "system.yaml").compiled
    assert kind_of(system.component("tab")).settings(system.component("tab")) == ()  # type: ignore[attr-defined]
    with pytest.raises(SettingError, match="a table's values are not settings"):
        apply_kind_setting(system, "tab.v.value", 1)


def test_the_runner_moves_a_body_before_the_first_step(scene: fmionnx.System) -> None:
    changed = apply_kind_setting(scene.compiled, "world.body.post.pos", (2.0, -1.0, 0.0))
    changed = apply_kind_setting(changed, "world.body.post.pos.z", 3)
    changed = apply_kind_setting(changed, "world.numeric.gains", (5, 6))
    record = (PortRef("world", "tip.pos"),)
    result = dataclasses.replace(scene, compiled=changed).run(isolate="none", signals=record)
    assert [result[f"world.tip.pos[{i}]"][0] for i in range(3)] == [2.0, -1.0, 3.5]
    base = scene.run(isolate="none", signals=record)
    assert [base[f"world.tip.pos[{i}]"][0] for i in range(3)] == [1.0, 0.0, 0.5]

    runner = make_runner(changed.component("world"))
    runner.instantiate()
    try:
        assert list(runner._model.numeric_data) == [5.0, 6.0]  # type: ignore[attr-defined]
    finally:
        runner.terminate()
