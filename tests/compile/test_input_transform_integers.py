"""A system input reaching an integer port through ``factor``/``offset`` (a bug hunt).

``inputs: {lvl: {to: [{to: c.n, factor: 2, offset: 1}]}}`` with ``c.n`` an Integer could never
be set: ``factor*value + offset`` was computed as a float (7.0) and refused as not an
integer, by ``--param lvl=3`` and by the input's own ``value: 3`` alike. A whole result now
sets the integer; one that is not whole is refused naming the transformation (never
rounded), and a factor or offset that is not whole is W031 when the file is compiled.

The refusals are built from an OverrideError's parts, not by taking its text apart (a code
review): ``--param`` and the file's ``value`` word the same parts each their own way.
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
from fmionnx.core.types import PortRef

SYSTEM = """\
fmionnx: 1
name: levels
run: {{stop: 0.2, step: 0.1}}
components:
  c: {{kind: fmu, path: {count}}}
inputs:
  lvl: {{to: [{{to: c.n, factor: {factor}, offset: 1}}]{value}}}
"""


def _system(
    tmp_path: Path,
    fixture_fmu: Callable[[str], Path],
    *,
    factor: str = "2",
    value: str | None = None,
) -> Path:
    path = tmp_path / "levels.yaml"
    text = SYSTEM.format(
        count=fixture_fmu("Count2"),
        factor=factor,
        value="" if value is None else f", value: {value}",
    )
    path.write_text(text, encoding="utf-8")
    return path


def _n(system: fmionnx.System) -> tuple[object, ...]:
    (count,) = system.compiled.components
    return next(p.value for p in count.parameters if p.port == "n")


def test_the_files_value_sets_the_whole_result_as_an_integer(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu, value="3"))
    assert _n(system) == (7,)
    assert type(_n(system)[0]) is int
    assert system.run(isolate="none")["c.m"][0] == 21  # 3*n at the first step


@pytest.mark.parametrize(("given", "expected"), [(3, 7), (3.5, 8), (-1, -1)])
def test_param_sets_a_whole_result_as_an_integer(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], given: float, expected: int
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu))
    assert _n(system.with_overrides(params={"lvl": given})) == (expected,)


def test_the_command_line_sets_it_too(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> None:
    path = _system(tmp_path, fixture_fmu)
    done = CliRunner().invoke(app, ["run", str(path), "-p", "lvl=3", "--no-out", "-q"])
    assert done.exit_code == 0, done.output


def test_a_result_that_is_not_whole_is_refused_naming_the_transformation(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    path = _system(tmp_path, fixture_fmu)
    with pytest.raises(OverrideError) as refused:
        fmionnx.load(path).with_overrides(params={"lvl": 3.3})
    assert str(refused.value) == (
        "--param `lvl`: 3.3 becomes 7.6 at `c.n` (factor 2, offset 1), which takes whole "
        "numbers (int32)"
    )
    done = CliRunner().invoke(app, ["run", str(path), "-p", "lvl=3.3", "--no-out"])
    assert done.exit_code == 2
    assert "becomes 7.6 at `c.n` (factor 2, offset 1)" in done.output
    assert "Traceback" not in done.output


def test_the_files_value_that_is_not_whole_is_e043_at_the_value(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(tmp_path, fixture_fmu, value="3.3"))
    (error,) = [d for d in refused.value.diagnostics if d.code == "E043"]
    assert error.message == (
        "system input `lvl`: 3.3 becomes 7.6 at `c.n` (factor 2, offset 1), which takes whole "
        "numbers (int32)"
    )
    assert error.span is not None
    assert error.span.line == 7


def test_a_factor_that_is_not_whole_is_w031_when_compiled(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu, factor="0.5"))
    (warning,) = [d for d in system.diagnostics if d.code == "W031"]
    assert warning.message.startswith(
        "system input `lvl` reaches `c.n` (int32) through factor 0.5, offset 1: "
    )
    assert _n(system.with_overrides(params={"lvl": 4})) == (3,)  # whole: set
    with pytest.raises(OverrideError, match=r"becomes 2\.5 at `c\.n`"):
        system.with_overrides(params={"lvl": 3})


# -- OverrideError's parts ------------------------------------------------------------------


def test_a_refusal_at_the_port_reached_has_its_parts(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu))
    with pytest.raises(OverrideError) as refused:
        system.with_overrides(params={"lvl": 2**40})
    error = refused.value
    assert error.subject == "--param `lvl`"
    assert error.reached == PortRef("c", "n")
    assert error.detail == (
        f"{2 * 2**40 + 1} is outside the range of int32 (-2147483648 to 2147483647)"
    )
    assert str(error) == f"--param `lvl` (a system input, reaching `c.n`): {error.detail}"
    assert error.worded("system input `lvl`", reaching="at") == (
        f"system input `lvl` (at `c.n`): {error.detail}"
    )


def test_a_refusal_of_the_port_itself_has_no_port_reached(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    system = fmionnx.load(_system(tmp_path, fixture_fmu))
    with pytest.raises(OverrideError) as refused:
        system.with_overrides(params={"c.n": "many"})
    error = refused.value
    assert (error.subject, error.reached) == ("--param `c.n`", None)
    assert str(error) == f"--param `c.n`: {error.detail}"
    assert error.detail.startswith("expected 1 value(s) of type int32")
