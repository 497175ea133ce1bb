"""A system input's own ``value`` sets the ports it reaches, as ``--param NAME=value`` does.

A bug hunt found ``inputs: {kk: {to: [gain.k], value: 3}}`` compiled and ran with ``gain.k``
at its own start value: the value reached nothing (an SSP connector's bound value does reach
its ports, along the connections it flows through), and ``value: .nan`` was accepted.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

import fmionnx
from fmionnx.core.errors import DiagnosticError
from fmionnx.core.types import ValueSource

SYSTEM = """\
fmionnx: 1
name: held
run: {{stop: 0.1, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}}}
inputs:
  level: {{to: [gain.k, {{to: gain.u, factor: 2, offset: 1}}], value: {value}}}
"""


def _system(tmp_path: Path, fixture_fmu: Callable[[str], Path], value: str) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(gain=fixture_fmu("Gain"), value=value), encoding="utf-8")
    return path


def _parameters(system: fmionnx.System) -> dict[str, tuple[object, ...]]:
    (gain,) = system.compiled.components
    return {p.port: p.value for p in gain.parameters}


def test_the_value_sets_every_port_it_reaches_through_its_transformation(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu, "3"))
    assert _parameters(system) == {"k": (3.0,), "u": (7.0,)}
    (gain,) = system.compiled.components
    assert {p.source for p in gain.parameters} == {ValueSource.SYSTEM_FILE}
    assert system.run()["gain.y"][-1] == pytest.approx(21.0)  # k * u


def test_param_on_the_command_line_replaces_the_value(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu, "3")).with_overrides(params={"level": 5})
    assert _parameters(system) == {"k": (5.0,), "u": (11.0,)}


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (".nan", "system input `level`: nan is not a number (NaN)"),
        ('"high"', "system input `level` (at `gain.k`): expected 1 value(s) of type float64"),
    ],
)
def test_a_value_no_port_can_take_is_e043_at_the_value(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], value: str, expected: str
) -> None:
    path = _system(tmp_path, fixture_fmu, value)
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(path)
    (error,) = refused.value.diagnostics
    assert error.code == "E043"
    assert error.message.startswith(expected), error.message
    assert error.span is not None
    assert error.span.line == 7
    line = path.read_text(encoding="utf-8").splitlines()[6]
    assert line[error.span.col - 1 :] == f"{value}}}", line  # at the value


def test_a_port_the_value_reaches_set_otherwise_in_the_file_is_e043_with_both_places(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    """The review of this change: the input's value silently replaced the component's own
    `parameters:` entry (5 became 3), and run.json lost where the value was written."""
    path = tmp_path / "system.yaml"
    text = SYSTEM.format(gain=fixture_fmu("Gain"), value="3").replace(
        "path: " + str(fixture_fmu("Gain")) + "}",
        "path: " + str(fixture_fmu("Gain")) + ", parameters: {k: 5}}",
    )
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(path)
    (error,) = refused.value.diagnostics
    assert error.message == (
        "system input `level` sets `gain.k` to 3.0, which `components.gain.parameters` sets to 5.0"
    )  # whole numbers on float ports compile as floats, as `--param gain.k=5` gives them
    assert [note.span.line for note in error.notes if note.span is not None] == [5]
    path.write_text(text.replace("k: 5", "k: 3"), encoding="utf-8")  # the same value: fine
    (gain,) = fmionnx.load(path).compiled.components
    (k,) = [p for p in gain.parameters if p.port == "k"]
    assert k.value == (3.0,)
    assert k.span is not None
    assert k.span.line == 7  # where the input's value is written
