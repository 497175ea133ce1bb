"""FMI 3 ``<Alias>`` names are ports: inspected, connected, recorded (issue #13).

``Scale3`` declares ``u_in`` as an alias of its input ``u`` and ``y_out``, ``y_copy`` as
aliases of its output ``y``; each reads or writes the value reference of its variable.
"""

from __future__ import annotations

import csv
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.core.types import Causality
from fmionnx.kinds.fmu.kind import load_fmu_interface
from tests.conftest import FIXTURES

SYSTEM = """\
fmionnx: 1
name: aliases
run: {{stop: 0.03, step: 0.01}}
record: [{record}]
components:
  a: {{kind: fmu, path: Scale3.fmu, parameters: {{{parameter}: 2.0}}}}
  b: {{kind: fmu, path: Scale3.fmu}}
connections:
  - a.y_out -> b.u_in
"""


@pytest.fixture
def scale3(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    shutil.copy(fixture_fmu("Scale3"), tmp_path / "Scale3.fmu")
    return tmp_path


def _run(folder: Path, record: str, parameter: str = "u") -> list[dict[str, str]]:
    system = folder / "system.yaml"
    system.write_text(SYSTEM.format(record=record, parameter=parameter), encoding="utf-8")
    result = CliRunner().invoke(app, ["run", str(system), "--out", str(folder / "out"), "-q"])
    assert result.exit_code == 0, result.output
    with (folder / "out" / "results.csv").open(encoding="utf-8") as file:
        return list(csv.DictReader(file))


def test_aliases_are_ports_of_their_variable() -> None:
    interface = load_fmu_interface(FIXTURES / "fmus" / "Scale3")
    ports = {p.name: p for p in interface.ports}
    assert [p.name for p in interface.ports] == ["u", "u_in", "y", "y_out", "y_copy"]
    assert ports["u_in"].vrs == ports["u"].vrs
    assert ports["u_in"].causality is Causality.INPUT
    assert ports["y_out"].vrs == ports["y_copy"].vrs == ports["y"].vrs
    assert ports["y_out"].description == "another name of y"
    assert ports["y_copy"].description == ""
    assert ports["y_out"].depends_on == ("u",)


def test_a_connection_between_aliases_carries_the_value(scale3: Path) -> None:
    rows = _run(scale3, "a.y, a.y_out, a.y_copy, b.y, b.y_out")
    assert list(rows[0]) == ["time", "a.y", "a.y_out", "a.y_copy", "b.y", "b.y_out"]
    for row in rows:
        assert float(row["a.y"]) == float(row["a.y_out"]) == float(row["a.y_copy"]) == 6.5
    for row in rows[1:]:
        assert float(row["b.y"]) == float(row["b.y_out"]) == 3.0 * 6.5 + 0.5


def test_a_parameter_on_an_alias_input_reaches_the_variable(scale3: Path) -> None:
    rows = _run(scale3, "a.y", parameter="u_in")
    assert all(float(row["a.y"]) == 6.5 for row in rows)


def test_an_unset_alias_does_not_overwrite_its_driven_variable(scale3: Path) -> None:
    """``a.u`` is given; its alias ``u_in`` (start 0) is not set, so ``y`` sees 2."""
    rows = _run(scale3, "a.y, a.u, a.u_in")
    assert list(rows[0]) == ["time", "a.y", "a.u"]  # an unset alias has no run-time buffer
    assert all(float(row["a.y"]) == 6.5 for row in rows)


def test_an_unknown_port_still_lists_the_aliases(scale3: Path) -> None:
    system = scale3 / "system.yaml"
    system.write_text(
        SYSTEM.format(record="a.nope", parameter="u").replace("a.y_out", "a.y_ou"),
        encoding="utf-8",
    )
    result = CliRunner().invoke(app, ["validate", str(system)], env={"COLUMNS": "1000"})
    assert result.exit_code == 1
    assert "E021" in result.output
    assert "y_out" in result.output  # did you mean


def test_a_variable_and_its_alias_both_given_is_a_clean_fault(scale3: Path) -> None:
    system = scale3 / "system.yaml"
    system.write_text(
        SYSTEM.format(record="b.y", parameter="u").replace(
            "b: {kind: fmu, path: Scale3.fmu}",
            "b: {kind: fmu, path: Scale3.fmu, parameters: {u: 1.0}}",
        ),
        encoding="utf-8",
    )
    result = CliRunner().invoke(app, ["run", str(system), "--out", str(scale3 / "out")])
    assert result.exit_code == 1
    assert "`u` and `u_in` name the same FMU variable" in " ".join(result.output.split())
    assert "Traceback" not in result.output
