"""A MuJoCo actuator's ``ctrlrange`` bounds its input port where MuJoCo clamps to it.

MuJoCo clamps a limited actuator's control to its ``ctrlrange`` without a word: a system
with ``parameters: {auto_lim: 5}`` for a ``[-1, 1]`` actuator ran with 1. The range is now
the port's min/max, so a value set outside it (``parameters:``, ``--param``, a study's
values) is E043 as an FMU's is. Ranges MuJoCo does not clamp to (not limited, or
``clampctrl`` disabled) bound nothing.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import fmionnx
from fmionnx.compile.overrides import OverrideError
from fmionnx.core.errors import DiagnosticError
from tests.conftest import cli

#: ``auto_lim`` is limited by ``autolimits`` (a ctrlrange, no ctrllimited), ``lim`` by
#: ``ctrllimited``, ``free`` not at all, ``off`` explicitly not.
SCENE = """\
<mujoco>
  <option timestep="0.01">{flag}</option>
  <worldbody>
    <body><joint name="slide" type="slide"/><geom size="0.1" mass="1"/></body>
  </worldbody>
  <actuator>
    <motor name="auto_lim" joint="slide" ctrlrange="-1 1"/>
    <motor name="lim" joint="slide" ctrllimited="true" ctrlrange="0.5 2"/>
    <motor name="free" joint="slide"/>
    <motor name="off" joint="slide" ctrllimited="false" ctrlrange="-1 1"/>
  </actuator>
</mujoco>
"""


def _system(tmp_path: Path, parameters: str, *, clamped: bool = True) -> Path:
    flag = "" if clamped else '<flag clampctrl="disable"/>'
    (tmp_path / "scene.xml").write_text(SCENE.format(flag=flag), encoding="utf-8")
    path = tmp_path / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: limits\nrun: {stop: 0.02, step: 0.01}\ncomponents:\n"
        f"  world: {{kind: mujoco, path: scene.xml, cameras: {{}}, parameters: {parameters}}}\n"
        "connections: []\n",
        encoding="utf-8",
    )
    return path


@pytest.mark.parametrize(
    ("parameters", "expected"),
    [
        ("{auto_lim: 5}", "`world.auto_lim`: 5 is above the declared max 1 of `auto_lim`"),
        ("{lim: 0.25}", "`world.lim`: 0.25 is below the declared min 0.5 of `lim`"),
    ],
)
def test_a_parameter_outside_the_ctrlrange_is_e043(
    tmp_path: Path, parameters: str, expected: str
) -> None:
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(tmp_path, parameters))
    (error,) = refused.value.diagnostics
    assert (error.code, error.message) == ("E043", expected)


def test_values_inside_the_range_or_of_unlimited_actuators_are_allowed(tmp_path: Path) -> None:
    parameters = "{auto_lim: 1, lim: 0.5, free: 50, off: 50}"
    assert fmionnx.load(_system(tmp_path, parameters)).compiled is not None


def test_a_range_mujoco_does_not_clamp_to_bounds_nothing(tmp_path: Path) -> None:
    system = fmionnx.load(_system(tmp_path, "{auto_lim: 5}", clamped=False))
    port = system.compiled.component("world").interface.port("auto_lim")
    assert port is not None
    assert port.bounds == (None, None)
    assert "not clamped" in port.description


def test_param_and_study_values_outside_the_range_are_refused(tmp_path: Path) -> None:
    system = fmionnx.load(_system(tmp_path, "{}"))
    port = system.compiled.component("world").interface.port("auto_lim")
    assert port is not None
    assert port.bounds == (-1.0, 1.0)
    with pytest.raises(OverrideError, match=r"5 is above the declared max 1 of `auto_lim`"):
        system.with_overrides(params={"world.auto_lim": 5})
    assert system.with_overrides(params={"world.auto_lim": -1}) is not None
    code, output = cli("run", str(tmp_path / "system.yaml"), "--no-out", "-p", "world.lim=3")
    assert code == 2, output
    assert "3 is above the declared max 2 of `lim`" in output
