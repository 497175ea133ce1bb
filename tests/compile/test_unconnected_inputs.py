"""Unconnected inputs: one W030 per component listing its ports, at the component (issue #16).

A ReadOdometry with nothing connected used to give six separate four-line warnings; now it is
one diagnostic that still points at ``file:line:col`` of the component's entry.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.compile.compiler import _warn_unconnected
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.types import Causality, DType, Port
from fmionnx.spec.sourcemap import SourceMap
from tests.conftest import built_model

GOLDEN = Path(__file__).resolve().parent / "golden" / "unconnected-odometry.txt"

SYSTEM = """\
fmionnx: 1
name: odo
run: {stop: 0.1, step: 0.01}
components:
  odometry: {kind: fmu, path: ReadOdometry.fmu}
"""


def test_a_lone_read_odometry_gives_one_warning_naming_its_six_inputs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    shutil.copy(built_model("ReadOdometry.fmu"), tmp_path / "ReadOdometry.fmu")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["validate", "system.yaml"], env={"COLUMNS": "200"})
    assert result.exit_code == 0
    assert result.output == GOLDEN.read_text(encoding="utf-8")


def _port(name: str, start: float | None) -> Port:
    return Port(name, Causality.INPUT, DType.FLOAT64, start=None if start is None else (start,))


@pytest.mark.parametrize(
    ("ports", "message", "hint_start"),
    [
        ([_port("u", 1.0)], "input `c.u` is not connected; its start value is used", "connect it,"),
        ([_port("u", None)], "input `c.u` is not connected; zero is used", "connect it,"),
        (
            [_port("u", 1.0), _port("v", 2.0)],
            "2 inputs of `c` are not connected: `u`, `v`; their start values are used",
            "connect them,",
        ),
        (
            [_port("u", None), _port("v", None)],
            "2 inputs of `c` are not connected: `u`, `v`; zero is used for each",
            "connect them,",
        ),
        (
            [_port("u", 1.0), _port("v", None), _port("w", None)],
            "3 inputs of `c` are not connected: `u`, `v`, `w`; "
            "their start values are used (zero for `v`, `w`)",
            "connect them,",
        ),
    ],
)
def test_the_warning_says_which_value_each_input_gets(
    ports: list[Port], message: str, hint_start: str
) -> None:
    bag = DiagnosticBag()
    _warn_unconnected("c", ports, SourceMap(Path("system.yaml")), bag)
    (diagnostic,) = bag
    assert diagnostic.code == "W030"
    assert diagnostic.message == message
    assert diagnostic.hint is not None
    assert diagnostic.hint.startswith(hint_start)
    assert isinstance(diagnostic.span, Span)
