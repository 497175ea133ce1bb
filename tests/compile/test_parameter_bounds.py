"""A value set before initialization outside the variable's declared ``min``/``max`` is E043.

A bug hunt ran Faulty with ``-p mode=99`` (``max="13"``): accepted, the model ran in a mode
its author ruled out. FMI makes such a value an error of whoever sets it; the file's
``parameters:``, ``--param``, a study's values and a system input's value are all checked.
Values that flow along connections during the run are the models' own business (as in every
other co-simulation master).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.compile.overrides import OverrideError
from fmionnx.core.errors import DiagnosticError
from tests.conftest import built_model

SYSTEM = """\
fmionnx: 1
name: bounded
run: {{stop: 0.1, step: 0.01}}
components:
  bad: {{kind: fmu, path: {faulty}, parameters: {{failAt: 10, mode: {mode}}}}}
"""


def _system(tmp_path: Path, fixture_fmu: Callable[[str], Path], mode: str) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(faulty=fixture_fmu("Faulty"), mode=mode), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("mode", "expected"),
    [
        ("99", "`bad.mode`: 99 is above the declared max 14 of `mode`"),
        ("-1", "`bad.mode`: -1 is below the declared min 0 of `mode`"),
    ],
)
def test_a_parameter_beyond_its_bounds_is_e043(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], mode: str, expected: str
) -> None:
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(tmp_path, fixture_fmu, mode))
    (error,) = refused.value.diagnostics
    assert (error.code, error.message) == ("E043", expected)


def test_the_bounds_themselves_are_allowed(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    for mode in ("0", "14"):
        assert fmionnx.load(_system(tmp_path, fixture_fmu, mode)).compiled is not None


def test_param_beyond_the_bounds_is_refused_with_the_bound(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu, "0"))
    with pytest.raises(OverrideError, match=r"--param `bad.mode`: 15 is above the declared max 14"):
        system.with_overrides(params={"bad.mode": 15})
    result = CliRunner().invoke(
        app, ["run", str(built_model("SignTrackingLogic.fmu")), "--no-out", "-p", "turnRate=-0.5"]
    )
    assert result.exit_code == 2, result.output
    assert "turnRate=-0.5" not in result.output  # the message names the value, not the option
    assert "-0.5 is below the declared min 0 of `turnRate`" in result.output
