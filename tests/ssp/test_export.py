"""`fmionnx export`: SSPs that are XSD-valid and open in FMPy and libcosim; `convert` back."""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest
from lxml import etree
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.spec.ssp_xml import schema

DEMO = """fmionnx: 1
name: demo
description: integrator into two gains
run: {{stop: 1, step: 0.01}}
components:
  integ: {{kind: fmu, path: {integrator}, parameters: {{u: 1.0}}}}
  g1: {{kind: fmu, path: {gain}, period: 0.02, parameters: {{k: 3}}}}
  g2: {{kind: fmu, path: {gain}, interface: me}}
connections:
  - integ.x -> g1.u
  - {{from: g1.y, to: g2.u, factor: 2.0, offset: 1.0}}
record: [g2.y]
"""


@pytest.fixture
def demo_yaml(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    path = tmp_path / "demo.yaml"
    text = DEMO.format(integrator=fixture_fmu("Integrator"), gain=fixture_fmu("Gain"))
    path.write_text(text, encoding="utf-8")
    return path


def export(system: Path, output: Path) -> Path:
    result = CliRunner().invoke(app, ["export", str(system), "-o", str(output)])
    assert result.exit_code == 0, result.output
    return output


def test_exported_ssd_and_ssv_files_validate_against_the_ssp_1_0_xsd(
    demo_yaml: Path, tmp_path: Path
) -> None:
    archive = export(demo_yaml, tmp_path / "demo.ssp")
    with zipfile.ZipFile(archive) as members:
        names = members.namelist()
        ssd = etree.fromstring(members.read("SystemStructure.ssd"))
        ssvs = [etree.fromstring(members.read(n)) for n in names if n.endswith(".ssv")]
    assert schema("ssd", "1").validate(etree.ElementTree(ssd)), schema("ssd", "1").error_log
    assert ssvs
    for ssv in ssvs:
        assert schema("ssv", "1").validate(etree.ElementTree(ssv))
    assert ssd.get("version") == "1.0"
    assert {"resources/integ.fmu", "resources/g1.fmu", "resources/g1.ssv"} <= set(names)


def test_fmpy_reads_the_exported_ssp(demo_yaml: Path, tmp_path: Path) -> None:
    from fmpy.ssp.ssd import read_ssd

    archive = export(demo_yaml, tmp_path / "demo.ssp")
    ssd = read_ssd(str(archive))  # validates against FMPy's own SSP 1.0 schema
    components = {c.name: c for c in ssd.system.elements}
    assert set(components) == {"integ", "g1", "g2"}
    assert components["g1"].source == "resources/g1.fmu"
    values = components["g1"].parameterBindings[0].parameterValues[0].parameters
    assert [(p.name, p.type, p.value) for p in values] == [("k", "Real", "3.0")]
    ends = {
        (c.startElement, c.startConnector, c.endElement, c.endConnector)
        for c in ssd.system.connections
    }
    assert ends == {("integ", "x", "g1", "u"), ("g1", "y", "g2", "u")}


def test_fmpy_simulates_the_exported_fmu_only_ssp(tmp_path: Path, fixture_fmu) -> None:
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import read_ssv

    system = tmp_path / "chain.yaml"
    system.write_text(
        "fmionnx: 1\nname: chain\nrun: {stop: 1, step: 0.01}\ncomponents:\n"
        f"  integ: {{kind: fmu, path: {fixture_fmu('Integrator')}, parameters: {{u: 1.0}}}}\n"
        f"  g1: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{k: 3}}}}\n"
        f"  g2: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "connections: [integ.x -> g1.u, g1.y -> g2.u]\n",
        encoding="utf-8",
    )
    archive = export(system, tmp_path / "chain.ssp")
    # FMPy's simulate_ssp ignores ParameterBindings: hand it our .ssv values under the
    # hierarchical names it expects, read with FMPy's own .ssv reader.
    merged = read_ssv(str(archive), resource="resources/integ.ssv")
    for parameter in merged.parameters:
        parameter.name = "integ." + parameter.name
    for parameter in read_ssv(str(archive), resource="resources/g1.ssv").parameters:
        parameter.name = "g1." + parameter.name
        merged.parameters.append(parameter)
    theirs = simulate_ssp(str(archive), stop_time=1.0, step_size=0.01, parameter_set=merged)
    ours = fmionnx.load(system).run(isolate="none")
    assert theirs["integ.x"][-1] == pytest.approx(ours["integ.x"][-1], abs=0.011)
    # FMPy applies connections after all steps (one step of delay): k * u one step earlier.
    assert theirs["g1.y"][-1] == pytest.approx(3.0 * theirs["g1.u"][-2])
    assert theirs["g1.y"][-1] > 2.5


def test_libcosim_loads_and_runs_the_exported_ssp_with_its_transformation(
    demo_yaml: Path, tmp_path: Path
) -> None:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    archive = export(demo_yaml, tmp_path / "demo.ssp")
    execution = CosimExecution.from_ssp_file(str(archive), step_size=10_000_000)  # 0.01 s
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    assert execution.simulate_until(1_000_000_000)
    index = execution.slave_index_from_instance_name("g2")
    y = next(v.reference for v in execution.slave_variables(index) if v.name == b"y")
    (value,) = observer.last_real_values(index, [y])
    # g2.y = 2 * (2 * g1.y + 1) with g1.y = 3 t, up to libcosim's per-step delays at t = 1.
    assert 2 * (2 * 3 * 0.96 + 1) <= value <= 2 * (2 * 3 * 1.0 + 1)


def test_export_refuses_a_system_with_errors_and_writes_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "fmionnx: 1\nname: bad\ncomponents:\n  a: {kind: fmu, path: missing.fmu}\n",
        encoding="utf-8",
    )
    result = CliRunner().invoke(app, ["export", str(bad), "-o", str(tmp_path / "bad.ssp")])
    assert result.exit_code == 1
    assert "not exported" in result.output
    assert not (tmp_path / "bad.ssp").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml"]


def test_convert_writes_yaml_and_models_beside_it(demo_yaml: Path, tmp_path: Path) -> None:
    archive = export(demo_yaml, tmp_path / "demo.ssp")
    output = tmp_path / "back" / "demo.yaml"
    result = CliRunner().invoke(app, ["convert", str(archive), "-o", str(output)])
    assert result.exit_code == 0, result.output
    text = output.read_text(encoding="utf-8")
    assert "path: demo_files/resources/g1.fmu" in text
    assert "factor: 2.0" in text
    assert (tmp_path / "back" / "demo_files" / "resources" / "g1.fmu").is_file()


def test_convert_failure_leaves_no_half_written_files(demo_yaml: Path, tmp_path: Path) -> None:
    archive = export(demo_yaml, tmp_path / "demo.ssp")
    out = tmp_path / "out"
    out.mkdir()
    (out / "demo_files").write_text("taken\n")  # where the models go is taken by a file
    result = CliRunner().invoke(app, ["convert", str(archive), "-o", str(out / "demo.yaml")])
    assert result.exit_code == 2  # not ours: refused before anything is written
    assert "not written by" in result.output or "not extracted by" in result.output
    assert "--force" in result.output
    assert sorted(p.name for p in out.iterdir()) == ["demo_files"]
    assert (out / "demo_files").read_text() == "taken\n"


def test_convert_to_a_folder_is_a_usage_error_before_any_work(
    demo_yaml: Path, tmp_path: Path
) -> None:
    archive = export(demo_yaml, tmp_path / "demo.ssp")
    target = tmp_path / "out" / "demo.yaml"
    target.mkdir(parents=True)  # the target name is taken by a folder
    result = CliRunner().invoke(app, ["convert", str(archive), "-o", str(target)])
    assert result.exit_code == 2
    assert "is a folder; expected a file name" in " ".join(result.output.split())
    assert target.is_dir()
    assert list(target.iterdir()) == []
