"""``--param`` reaches a kind's settings (a signal's waveform numbers, a scene's values) as a
study's target does, through the same :class:`~fmionnx.kinds.base.Settable` capability."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.results.csvfile import read_csv

SYSTEM = """fmionnx: 1
name: driven
run: {{stop: 0.3, step: 0.1}}
components:
  src:
    kind: signal
    outputs:
      y: {{constant: 1.5}}
  gain: {{kind: fmu, path: {gain}}}
connections:
  - src.y -> gain.u
record: [src.y, gain.y]
"""


@pytest.fixture
def system(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    path = tmp_path / "driven.yaml"
    path.write_text(SYSTEM.format(gain=fixture_fmu("Gain")), encoding="utf-8")
    return path


def _run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["run", *args, "-q"], env={"COLUMNS": "300"})
    return result.exit_code, result.output


def test_a_signal_setting_changes_the_run(system: Path, tmp_path: Path) -> None:
    plain, changed = tmp_path / "plain", tmp_path / "changed"
    assert _run(str(system), "--out", str(plain))[0] == 0
    code, output = _run(str(system), "--out", str(changed), "-p", "src.value=4", "-p", "gain.k=3")
    assert code == 0, output
    before, after = read_csv(plain / "results.csv"), read_csv(changed / "results.csv")
    assert before["src.y"][-1] == 1.5
    assert before["gain.y"][-1] == 2 * 1.5
    assert after["src.y"][-1] == 4.0
    assert after["gain.y"][-1] == 3 * 4.0


def test_an_unknown_setting_names_the_settings_too(system: Path) -> None:
    code, output = _run(str(system), "--no-out", "-p", "src.valu=4")
    assert code == 2
    assert (
        "--param `src.valu`: `src` has no parameter or setting `valu`; did you mean `value`?"
        in (" ".join(output.split()))
    )


def test_a_refused_setting_is_a_usage_error_naming_it(system: Path) -> None:
    code, output = _run(str(system), "--no-out", "-p", 'src.value="high"')
    assert code == 2
    assert "--param `src.value`: `value` takes a number, got `high`" in " ".join(output.split())
    assert "Traceback" not in output


def test_an_fmu_without_settings_keeps_its_message(system: Path) -> None:
    code, output = _run(str(system), "--no-out", "-p", "gain.kk=4")
    assert code == 2
    assert "`gain` has no parameter `kk`; did you mean `k`?" in " ".join(output.split())
