"""The non-finite guard: a NaN or an infinity leaving a component on a connection.

``Faulty`` (tests/fixtures/fmus, built from our C sources) returns ``fmi2OK`` with ``y = NaN``
(mode 1) or ``y = +inf`` (mode 14) from ``failAt`` on. By default the run stops there with a
fault naming component, port and time, in the Python path and in the native kernel alike;
``on_nonfinite="warn"`` passes the value on and names it once among the run's warnings.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.runtime.result import RunStatus

INF = 14
NAN = 1


def _system(fixture_fmu, write_system, mode: int, *, chain: bool = False) -> Path:
    """Faulty feeding Gain (``chain``: Gain -> Faulty -> Gain). FMI 2 co-simulation FMUs of
    one period in a row are one native group, stepped by the C kernel unless
    ``FMIONNX_NATIVE=0``."""
    head = f"  first: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n" if chain else ""
    link = "  - first.y -> bad.u\n" if chain else ""
    return write_system(
        f"""
fmionnx: 1
name: nonfinite
run: {{stop: 1.0, step: 0.01}}
components:
{head}  bad: {{kind: fmu, path: {fixture_fmu("Faulty")}, parameters: {{mode: {mode}, failAt: 0.3}}}}
  gain: {{kind: fmu, path: {fixture_fmu("Gain")}}}
connections:
{link}  - bad.y -> gain.u
record: [bad.y, gain.y]
"""
    )


@pytest.mark.parametrize(("mode", "word"), [(INF, "inf"), (NAN, "NaN")])
@pytest.mark.parametrize("native", [False, True], ids=["python", "native-kernel"])
def test_a_nonfinite_output_is_a_fault_naming_component_port_and_time(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, mode: int, word: str, native: bool
) -> None:
    if not native:
        monkeypatch.setenv("FMIONNX_NATIVE", "0")  # the Python transfers
    system = fmionnx.load(_system(fixture_fmu, write_system, mode, chain=native))
    result = system.run(isolate="none")
    assert result.details["native"] is native
    assert result.status is RunStatus.FAULT
    error = result.error
    assert error is not None
    assert (error.component, error.port) == ("bad", "y")
    assert error.time == pytest.approx(0.3, abs=0.011)
    assert f": {word} on the connection `bad.y -> gain.u`" in str(error)
    assert str(error).startswith(f"component `bad`, port `y` at t={error.time:g} s")
    assert np.isfinite(result["gain.y"]).all()  # nothing non-finite got through


def test_warn_passes_the_value_on_and_names_it_once(fixture_fmu, write_system) -> None:
    system = fmionnx.load(_system(fixture_fmu, write_system, INF, chain=True))
    result = system.run(isolate="none", on_nonfinite="warn")
    assert result.status is RunStatus.COMPLETED
    assert result.steps_done == 100
    assert np.isinf(result["gain.y"][-1])  # passed on
    assert len(result.warnings) == 1
    warning = result.warnings[0]
    assert warning.startswith("component `bad`, port `y` at t=0.29 s: inf on the connection")
    assert "passed on (--on-nonfinite warn)" in warning
    assert "(71 transfers in all)" in warning  # bad steps before gain: t = 0.29 .. 0.99
    assert result.details["native"] is False  # the kernel would stop: Python path


def test_the_cli_warns_and_run_json_keeps_the_warning(fixture_fmu, write_system, tmp_path) -> None:
    path = _system(fixture_fmu, write_system, NAN)
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(path), "--out", str(out), "--isolate", "none", "--on-nonfinite", "warn"]
    )
    assert result.exit_code == 0, result.output
    output = " ".join(result.output.split())  # the console wraps long lines
    assert "warning: component `bad`, port `y` at t=0.29 s: NaN on the connection" in output
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "completed"
    assert len(info["warnings"]) == 1
    assert "NaN on the connection `bad.y -> gain.u`" in info["warnings"][0]


def test_the_default_is_a_fault_with_exit_status_1(fixture_fmu, write_system, tmp_path) -> None:
    path = _system(fixture_fmu, write_system, INF)
    result = CliRunner().invoke(
        app, ["run", str(path), "--out", str(tmp_path / "out"), "--isolate", "none"]
    )
    assert result.exit_code == 1
    output = " ".join(result.output.split())  # the console wraps long lines
    assert "fault: component `bad`, port `y` at t=0.29 s: inf on the connection" in output
    assert json.loads((tmp_path / "out" / "run.json").read_text())["error"]["port"] == "y"


def test_an_unknown_policy_is_a_usage_error(fixture_fmu, write_system) -> None:
    path = _system(fixture_fmu, write_system, INF)
    result = CliRunner().invoke(app, ["run", str(path), "--no-out", "--on-nonfinite", "ignore"])
    assert result.exit_code == 2
    assert "--on-nonfinite must be `fault` or `warn`, not `ignore`" in result.output
