"""A study's values: written numbers are tried as written, generated ones (a range's, a
sample's) are rounded and stay within their bounds however large, a range of whole numbers
varies an integer parameter, and ``null`` is said not to be a value."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.compile.study import compile_study
from fmionnx.compile.studyir import StudyPlan
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.study import load_study
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: s
run: {stop: 1, step: 0.1}
components:
  g: {kind: fmu, path: Gain.fmu}
  c: {kind: fmu, path: Count2.fmu}
"""


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A system of a Gain (float parameter ``k``) and a Count2 (int32 input ``n``)."""
    for name in ("Gain", "Count2"):
        shutil.copy(build_fixture_fmu(name), tmp_path / f"{name}.fmu")
    (tmp_path / "sys.yaml").write_text(SYSTEM, encoding="utf-8")
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _study(parameters: str, more: str = "") -> str:
    return f"fmionnx: 1\nsystem: sys.yaml\nparameters: {parameters}\n{more}"


def _plan(folder: Path, text: str) -> tuple[StudyPlan | None, list[str]]:
    path = folder / "study.yaml"
    path.write_text(text, encoding="utf-8")
    bag = DiagnosticBag()
    plan = compile_study(load_study(path, bag), bag)
    errors = [f"{d.code} {d.message}" for d in bag.sorted() if d.severity.name == "ERROR"]
    return plan, errors


def _values(plan: StudyPlan | None, target: str) -> list[object]:
    assert plan is not None
    return [s.value for case in plan.cases for s in case.settings if s.target == target]


@pytest.mark.parametrize(
    "axis", ["[1.0000000000001, 1.0000000000002]", "{values: [1.0000000000001, 1.0000000000002]}"]
)
def test_written_values_are_tried_as_written(folder: Path, axis: str) -> None:
    plan, errors = _plan(folder, _study(f"{{g.k: {axis}}}"))
    assert errors == []
    assert _values(plan, "g.k") == [1.0000000000001, 1.0000000000002]


def test_a_range_rounds_what_it_generates_and_keeps_its_ends(folder: Path) -> None:
    plan, _ = _plan(folder, _study("{g.k: {range: {start: 0, stop: 1, num: 4}}}"))
    assert _values(plan, "g.k") == [0.0, 0.333333333333, 0.666666666667, 1.0]
    ends = "{g.k: {range: {start: 1.0000000000001, stop: 1.0000000000003, num: 3}}}"
    values = _values(_plan(folder, _study(ends))[0], "g.k")
    assert values[0] == 1.0000000000001
    assert values[2] == 1.0000000000003
    assert 1.0000000000001 < values[1] < 1.0000000000003  # not rounded out of the range (1.0)


@pytest.mark.parametrize(
    ("start", "stop"), [("0", "1e308"), ("-1.7e308", "1.7e308"), ("1.7e308", "-1.7e308")]
)
def test_a_range_up_to_the_float_limit_is_finite(folder: Path, start: str, stop: str) -> None:
    axis = f"{{g.k: {{range: {{start: {start}, stop: {stop}, num: 5}}}}}}"
    plan, errors = _plan(folder, _study(axis))
    assert errors == []
    values = _values(plan, "g.k")
    assert len(values) == 5
    low, high = sorted((float(start), float(stop)))
    assert all(isinstance(v, float) and math.isfinite(v) and low <= v <= high for v in values)
    assert values[0] == float(start)
    assert values[-1] == float(stop)
    assert len(set(values)) == 5


@pytest.mark.parametrize("method", ["random", "latin_hypercube"])
@pytest.mark.parametrize(
    ("low", "high"), [(-1.7e308, 1.7e308), (-1.7976931348623157e308, 1.7976931348623157e308)]
)
def test_samples_near_the_float_limit_are_finite_and_within_their_bounds(
    folder: Path, method: str, low: float, high: float
) -> None:
    axis = f"{{g.k: {{{method}: {{low: {low!r}, high: {high!r}}}}}}}"
    plan, errors = _plan(folder, _study(axis, "sampling: {samples: 20, seed: 3}\n"))
    assert errors == []
    values = _values(plan, "g.k")
    assert len(set(values)) == 20
    assert all(isinstance(v, float) and low <= v < high for v in values)


def test_samples_in_a_narrow_interval_stay_below_its_high_bound(folder: Path) -> None:
    """Rounded to 12 digits, a draw near ``high`` would be ``high`` itself."""
    axis = "{g.k: {random: {low: 0.9999999999999, high: 1}}}"
    plan, errors = _plan(folder, _study(axis, "sampling: {samples: 50, seed: 0}\n"))
    assert errors == []
    assert all(0.9999999999999 <= v < 1 for v in _values(plan, "g.k"))  # type: ignore[operator]


def test_a_range_of_whole_numbers_varies_an_integer_parameter(folder: Path) -> None:
    axes = (
        "{c.n: {range: {start: 0, stop: 10, num: 11}}, g.k: {range: {start: 2, stop: 6, num: 3}}}"
    )
    plan, errors = _plan(folder, _study(axes))
    assert errors == []
    assert plan is not None
    assert [s.value for s in plan.cases[-1].settings] == [10, 6]
    tried = _values(plan, "c.n")
    assert sorted(set(tried)) == list(range(11))
    assert all(type(v) is int for v in tried)


def test_a_range_of_fractions_on_an_integer_parameter_says_how_to_get_integers(
    folder: Path,
) -> None:
    (folder / "study.yaml").write_text(
        _study("{c.n: {range: {start: 0, stop: 10, num: 4}}}"), encoding="utf-8"
    )
    result = CliRunner().invoke(app, ["validate", "study.yaml"], env={"COLUMNS": "200"})
    assert result.exit_code == 1
    assert "error[E103 study-values]: `c.n`: expected 1 value(s) of type int32" in result.output
    assert "hint: a `range` gives integers when `start` and `stop` are written as integers" in (
        result.output
    )


@pytest.mark.parametrize(
    ("axis", "where"),
    [
        ("[null]", "3:20: error[E003 invalid-value]: `parameters.g.k[0]`"),
        ("{values: [1, null]}", "3:32: error[E003 invalid-value]: `parameters.g.k.values[1]`"),
        ("[[1, null]]", "3:24: error[E003 invalid-value]: `parameters.g.k[0][1]`"),
    ],
)
def test_null_is_said_not_to_be_a_value_at_its_place(folder: Path, axis: str, where: str) -> None:
    (folder / "study.yaml").write_text(_study(f"{{g.k: {axis}}}"), encoding="utf-8")
    result = CliRunner().invoke(app, ["validate", "study.yaml"], env={"COLUMNS": "200"})
    assert result.exit_code == 1
    assert f"study.yaml:{where}: null is not a value" in result.output
    assert "valid boolean (got None)" not in result.output
