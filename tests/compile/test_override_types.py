"""Overrides that depend on the port's type (a bug hunt of ``-p``, ``params=`` and a study's
values):

* an FMI 3 structural parameter that is an array port's ``<Dimension>`` was passed to the FMU
  with another value while the compiled ports kept their shape, so the run read and wrote the
  wrong number of values: a changed value is refused where it is set, naming the ports;
* ``-p blob=1234`` on a Binary parameter and ``-p label=12`` on a String one were read as JSON
  numbers and refused: a whole number on the command line is the text it was written as;
* hexadecimal text that is not whole bytes (``-p blob=0c0``) was found only when the run set
  it: it is refused at compile time, naming the parameter and what is expected.

The sized FMU is the ``Vector3`` fixture (arrays of a fixed three elements) with a model
description whose arrays take their size from a structural parameter ``n`` instead; nothing
here runs it, so its library need not know ``n``.
"""

from __future__ import annotations

import re
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.compile.overrides import OverrideError, override_parameter, parse_value
from fmionnx.compile.studyir import Setting, apply_setting
from fmionnx.core.errors import DiagnosticError
from fmionnx.core.types import ValueSource
from fmionnx.kinds.cache import clear_cache
from fmionnx.kinds.fmu.kind import FMU_KIND
from fmionnx.runtime.result import RunStatus

BuildFmu = Callable[[str], Path]

#: Vector3's fixed dimensions, replaced by the structural parameter `n` (value reference 6).
_FIXED = '<Dimension start="3"/>'
_SIZED = '<Dimension valueReference="6"/>'
_PARAMETERS = (
    '<UInt64 name="n" valueReference="6" causality="structuralParameter" variability="fixed" '
    'start="3"><Alias name="count_of_u"/></UInt64>\n'
    '    <UInt64 name="spare" valueReference="7" causality="structuralParameter" '
    'variability="fixed" start="1"/>\n    '
)


def _sized_description(fixed: str) -> str:
    """Vector3's description with `u` and `y` sized by `n` (and a `spare` sizing nothing)."""
    assert fixed.count(_FIXED) == 2
    text = fixed.replace(_FIXED, _SIZED)
    return text.replace('<Float64 name="u"', _PARAMETERS + '<Float64 name="u"', 1)


def _sized_fmu(folder: Path, fixture_fmu: BuildFmu) -> Path:
    """An unpacked FMU folder ``folder/V``: Vector3's files, the sized description."""
    unpacked = folder / "V"
    with zipfile.ZipFile(fixture_fmu("Vector3")) as archive:
        archive.extractall(unpacked)
    description = unpacked / "modelDescription.xml"
    description.write_text(_sized_description(description.read_text("utf-8")), "utf-8")
    return unpacked


def _system(folder: Path, fmu: Path, parameters: str = "{}") -> Path:
    path = folder / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: sized\nrun: {stop: 0.2, step: 0.1}\ncomponents:\n"
        f"  v: {{kind: fmu, path: {fmu}, parameters: {parameters}}}\n",
        encoding="utf-8",
    )
    return path


@pytest.fixture
def sized(tmp_path: Path, fixture_fmu: BuildFmu) -> fmionnx.System:
    return fmionnx.load(_system(tmp_path, _sized_fmu(tmp_path, fixture_fmu)))


# --- structural parameters that size ports


def test_the_interface_lists_the_ports_a_structural_parameter_sizes(
    tmp_path: Path, fixture_fmu: BuildFmu
) -> None:
    interface = FMU_KIND.read_interface(_sized_fmu(tmp_path, fixture_fmu), None)
    assert FMU_KIND.sized_ports(interface, "n") == ("u", "y")
    assert FMU_KIND.sized_ports(interface, "count_of_u") == ("u", "y")  # n's alias
    assert FMU_KIND.sized_ports(interface, "spare") == ()
    assert FMU_KIND.sized_ports(interface, "k") == ()


@pytest.mark.parametrize("name", ["v.n", "v.count_of_u"])
def test_a_changed_value_of_a_sizing_parameter_is_refused_naming_the_ports(
    sized: fmionnx.System, name: str
) -> None:
    expected = (
        f"--param `{name}`: `{name[2:]}` is a structural parameter that sizes `u` (shape [3]), "
        "`y` (shape [3]); fmionnx fixes a model's arrays at their default shape"
    )
    with pytest.raises(OverrideError, match=re.escape(expected)) as refused:
        sized.with_overrides(params={name: 4})
    assert "can only keep its start value 3 (got 4)" in str(refused.value)


def test_the_start_value_of_a_sizing_parameter_and_a_parameter_sizing_nothing_are_set(
    sized: fmionnx.System,
) -> None:
    system = sized.with_overrides(params={"v.n": 3, "v.spare": 5})
    (component,) = system.compiled.components
    assert {p.port: p.value for p in component.parameters} == {"n": (3,), "spare": (5,)}


def test_the_command_line_refuses_a_sizing_parameter_with_exit_2(
    tmp_path: Path, fixture_fmu: BuildFmu
) -> None:
    path = _system(tmp_path, _sized_fmu(tmp_path, fixture_fmu))
    result = CliRunner().invoke(app, ["run", str(path), "--no-out", "-p", "v.n=5"])
    assert result.exit_code == 2, result.output
    assert "--param `v.n`: `n` is a structural parameter that sizes `u`" in result.output
    assert "Traceback" not in result.output


def test_a_study_value_of_a_sizing_parameter_is_refused(sized: fmionnx.System) -> None:
    with pytest.raises(OverrideError, match="`n` is a structural parameter that sizes `u`"):
        apply_setting(sized.compiled, Setting("v.n", "parameter", 2))
    assert apply_setting(sized.compiled, Setting("v.n", "parameter", 3)) is not None


def test_the_system_file_refuses_a_sizing_parameter_at_its_value(
    tmp_path: Path, fixture_fmu: BuildFmu
) -> None:
    fmu = _sized_fmu(tmp_path, fixture_fmu)
    path = _system(tmp_path, fmu, "{n: 4}")
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(path)
    (error,) = refused.value.diagnostics
    assert error.code == "E043"
    assert error.message.startswith("`v.n`: `n` is a structural parameter that sizes `u`")
    assert error.span is not None
    line = path.read_text("utf-8").splitlines()[4]
    assert (error.span.line, error.span.col) == (5, line.index("4}") + 1)  # the value `4`
    assert fmionnx.load(_system(tmp_path, fmu, "{n: 3}")).compiled is not None


def test_a_kept_interface_still_knows_what_a_parameter_sizes(
    tmp_path: Path, fixture_fmu: BuildFmu
) -> None:
    unpacked = _sized_fmu(tmp_path, fixture_fmu)
    archive = tmp_path / "V.fmu"
    with zipfile.ZipFile(archive, "w") as packed:
        for file in sorted(unpacked.rglob("*")):
            if file.is_file():
                packed.write(file, file.relative_to(unpacked).as_posix())
    shutil.rmtree(unpacked)
    clear_cache()
    first = FMU_KIND.read_interface(archive, None)  # read with fmpy, and kept
    clear_cache()  # as a new process: read back from the cache folder
    kept = FMU_KIND.read_interface(archive, None)
    assert kept == first
    assert FMU_KIND.sized_ports(kept, "n") == ("u", "y")


# --- String and Binary values from the command line


def test_a_binary_parameter_given_as_digits_on_the_command_line_is_hex(
    fixture_fmu: BuildFmu,
) -> None:
    result = fmionnx.run(
        fixture_fmu("Binary3"), no_out=True, isolate="none", params={"blob": parse_value("1234")}
    ).result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["blobSize"][-1] == 2
    assert result.signals["blobValue"][-1] == 0x1234


def test_python_bytes_set_a_binary_parameter(fixture_fmu: BuildFmu) -> None:
    result = fmionnx.run(
        fixture_fmu("Binary3"), no_out=True, isolate="none", params={"blob": b"\x0c\x0d\xff"}
    ).result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["blobValue"][-1] == 0x0C0DFF


def test_a_string_parameter_given_as_a_number_on_the_command_line_is_its_text(
    fixture_fmu: BuildFmu,
) -> None:
    system = fmionnx.load(fixture_fmu("Strings2"))
    for text, expected in (("12", "12"), ("true", "true"), ('"1.50"', "1.50")):
        (component,) = system.with_overrides(
            params={"label": parse_value(text)}
        ).compiled.components
        assert {p.port: p.value for p in component.parameters}["label"] == (expected,)
    result = fmionnx.run(
        fixture_fmu("Strings2"), no_out=True, isolate="none", params={"label": parse_value("1234")}
    ).result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["labelLength"][-1] == 4


def test_a_fraction_for_a_string_is_refused_with_a_hint_to_quote_it(
    fixture_fmu: BuildFmu,
) -> None:
    system = fmionnx.load(fixture_fmu("Strings2"))
    with pytest.raises(OverrideError, match=r"got `1.5`; quote text that reads as a number"):
        system.with_overrides(params={"label": parse_value("1.50")})


def test_a_number_from_a_study_is_not_taken_as_text(fixture_fmu: BuildFmu) -> None:
    """A study's YAML has lost the text already (``0012`` reads as 12)."""
    compiled = fmionnx.load(fixture_fmu("Binary3")).compiled
    with pytest.raises(OverrideError, match="expected 1 value"):
        override_parameter(compiled, "blob", 12, ValueSource.STUDY)
    assert override_parameter(compiled, "blob", "0012", ValueSource.STUDY) is not None


@pytest.mark.parametrize("text", ["xyz", "0c0", "1e00", "0x12"])
def test_text_that_is_not_whole_hex_bytes_is_refused_at_compile_time(
    fixture_fmu: BuildFmu, text: str
) -> None:
    result = CliRunner().invoke(
        app, ["run", str(fixture_fmu("Binary3")), "--no-out", "-p", f"blob={text}"]
    )
    assert result.exit_code == 2, result.output
    assert "--param `blob`" in result.output
    assert "hexadecimal text" in result.output
    assert "running" not in result.output  # refused before anything ran


def test_hex_written_as_json_text_is_taken(fixture_fmu: BuildFmu) -> None:
    system = fmionnx.load(fixture_fmu("Binary3"))
    (component,) = system.with_overrides(params={"blob": parse_value('"1e00"')}).compiled.components
    assert component.parameters[-1].value == ("1e00",)
