"""YAML -> SSP -> YAML keeps the compiled system; the reference system runs bit for bit.

"Equal" compares the compiled IR without file locations: system name, description, run
start/stop/step, every component (name, kind, period, parameters, the model's ports and
content hash, its options except `path`), every connection (ends, element count, factor,
offset), the execution order, record, plots, checks and the ros2 section. Paths, spans and the
origins of run settings are left out: they say where things are, not what runs.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from typer.testing import CliRunner

import fmionnx
from fmionnx import api
from fmionnx.cli import app
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.types import Ros2Settings
from tests.conftest import REPO
from tests.ssp.test_export import DEMO


def _unordered(settings: Ros2Settings | None) -> object:
    """The ``ros2:`` settings with their entries as sets (a round trip may reorder them)."""
    if settings is None:
        return None
    return (
        settings.namespace,
        settings.distro,
        frozenset(settings.nodes),
        frozenset(settings.topics),
        frozenset(settings.qos),
    )


def fingerprint(system: CompiledSystem) -> dict[str, Any]:
    """What the system computes, without where its files are."""
    return {
        "name": system.name,
        "description": system.description,
        "run": (system.run.start, system.run.stop, system.run.step),
        "components": [
            {
                "name": c.name,
                "kind": c.kind,
                "period": (c.period, c.period_steps),
                "parameters": [(p.port, p.value) for p in c.parameters],
                "model": c.interface.content_hash,
                "ports": [
                    (p.name, p.causality, p.dtype, p.shape, p.unit) for p in c.interface.ports
                ],
                "options": (c.config, c.external),
            }
            for c in system.components
        ],
        "connections": [
            (str(c.src), str(c.dst), c.size, c.factor, c.offset) for c in system.connections
        ],
        "order": system.order,
        "record": [str(r) for r in system.record],
        "plots": [
            (p.xy, p.y, p.refs, p.series, p.title, p.file, p.path, p.scene) for p in system.plots
        ],
        "checks": [
            (c.name, c.expression, c.measure, c.comparison, c.bound, c.refs) for c in system.checks
        ],
        "ros2": _unordered(system.ros2),
    }


def round_trip(system: Path, folder: Path) -> tuple[Path, Path]:
    runner = CliRunner()
    archive = folder / f"{system.stem}.ssp"
    result = runner.invoke(app, ["export", str(system), "-o", str(archive)])
    assert result.exit_code == 0, result.output
    back = folder / "back" / f"{system.stem}.yaml"
    result = runner.invoke(app, ["convert", str(archive), "-o", str(back)])
    assert result.exit_code == 0, result.output
    return archive, back


def compiled(path: Path) -> CompiledSystem:
    result = api.compile_system(path)
    assert result.system is not None, result.diagnostics
    return result.system


def test_yaml_ssp_yaml_gives_an_equal_compiled_system(tmp_path: Path, fixture_fmu) -> None:
    system = tmp_path / "demo.yaml"
    system.write_text(
        DEMO.format(integrator=fixture_fmu("Integrator"), gain=fixture_fmu("Gain")),
        encoding="utf-8",
    )
    archive, back = round_trip(system, tmp_path)
    original = fingerprint(compiled(system))
    assert fingerprint(compiled(archive)) == original
    assert fingerprint(compiled(back)) == original


def test_round_trip_keeps_the_checks(tmp_path: Path, fixture_fmu) -> None:
    system = tmp_path / "demo.yaml"
    text = DEMO.format(integrator=fixture_fmu("Integrator"), gain=fixture_fmu("Gain"))
    text += "checks:\n  - name: grows\n    expect: first_time(g2.y > 1) < 0.5\n"
    system.write_text(text, encoding="utf-8")
    archive, back = round_trip(system, tmp_path)
    original = fingerprint(compiled(system))
    assert len(original["checks"]) == 1
    assert fingerprint(compiled(archive)) == original
    assert fingerprint(compiled(back)) == original


def test_round_trip_keeps_array_parameters_and_indexed_connections(
    tmp_path: Path, fixture_fmu
) -> None:
    system = tmp_path / "arrays.yaml"
    system.write_text(
        "fmionnx: 1\nname: arrays\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{v: [1.0, 2.0, 3.0]}}}}\n"
        f"  b: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "connections:\n  - a.w -> b.v\n  - a.w[2] -> b.u\n",
        encoding="utf-8",
    )
    archive, back = round_trip(system, tmp_path)
    original = fingerprint(compiled(system))
    assert fingerprint(compiled(archive)) == original
    assert fingerprint(compiled(back)) == original
    with zipfile.ZipFile(archive) as members:
        text = members.read("SystemStructure.ssd").decode()
    assert 'startConnector="w[3]"' in text  # FMI 2 element name of `a.w[2]`


def test_reference_system_exported_and_reimported_runs_bit_for_bit(tmp_path: Path) -> None:
    system = REPO / "systems" / "sign_follower.yaml"
    archive, back = round_trip(system, tmp_path)
    assert fingerprint(compiled(back)) == fingerprint(compiled(system))
    ours = fmionnx.load(system).run(isolate="none", stop_time=0.5)
    theirs = fmionnx.load(archive).run(isolate="none", stop_time=0.5)
    assert ours.signals.keys() == theirs.signals.keys()
    for name, values in ours.signals.items():
        np.testing.assert_array_equal(theirs.signals[name], values, err_msg=name)


def test_integers_beyond_32_bits_round_trip_through_the_annotation(
    tmp_path: Path, fixture_fmu
) -> None:
    """ssv:Integer is xs:int: an int64 or uint32 value travels in our annotation, unchanged."""
    system = tmp_path / "big.yaml"
    system.write_text(
        "fmionnx: 1\nname: big\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
        f"  t: {{kind: fmu, path: {fixture_fmu('Types3')}, parameters: "
        "{u_i64: 3000000000, u_u32: 4000000000, u_i32: -7, u_f32: 1.5}}\n"
        "inputs:\n  spare: {to: [], value: -20}\n",
        encoding="utf-8",
    )
    archive, back = round_trip(system, tmp_path)
    original = compiled(system)
    for other in (compiled(archive), compiled(back)):
        assert fingerprint(other) == fingerprint(original)
        assert other.content_hash == original.content_hash
    with zipfile.ZipFile(archive) as members:
        ssv = members.read("resources/t.ssv").decode()
        ssd = members.read("SystemStructure.ssd").decode()
    assert '<ssv:Integer value="-7"/>' in ssv
    assert "3000000000" not in ssv
    assert '"u_i64": 3000000000, "u_u32": 4000000000' in ssd


def test_system_input_values_beyond_32_bits_round_trip(tmp_path: Path, fixture_fmu) -> None:
    system = tmp_path / "inputs.yaml"
    system.write_text(
        "fmionnx: 1\nname: inputs\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
        f"  t: {{kind: fmu, path: {fixture_fmu('Types3')}}}\n"
        "inputs:\n  drive: {to: [t.u_i64], value: 9000000000}\n",
        encoding="utf-8",
    )
    archive, back = round_trip(system, tmp_path)
    original = compiled(system)
    for other in (compiled(archive), compiled(back)):
        assert [(i.name, i.value) for i in other.inputs] == [("drive", 9000000000)]
        assert other.content_hash == original.content_hash


def test_an_unconnected_system_input_is_declared_with_its_value_type(
    tmp_path: Path, fixture_fmu
) -> None:
    system = tmp_path / "spare.yaml"
    system.write_text(
        "fmionnx: 1\nname: spare\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
        f"  g: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "inputs:\n  spare: {to: [], value: -20}\n",
        encoding="utf-8",
    )
    archive, _ = round_trip(system, tmp_path)
    with zipfile.ZipFile(archive) as members:
        ssd = members.read("SystemStructure.ssd").decode()
    connector = ssd.split('<ssd:Connector name="spare"', 1)[1].split("</ssd:Connector>", 1)[0]
    assert "<ssc:Integer/>" in connector
    assert '<ssv:Integer value="-20"/>' in ssd


def test_round_trip_keeps_the_order_of_a_signals_outputs(tmp_path: Path) -> None:
    """The annotation keeps keys as written: output order is port and column order."""
    system = tmp_path / "sig.yaml"
    system.write_text(
        "fmionnx: 1\nname: sig\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        "  s: {kind: signal, outputs: {t: {constant: 50, unit: degF}, "
        "p: {constant: 2, unit: kW}}}\n",
        encoding="utf-8",
    )
    archive, back = round_trip(system, tmp_path)
    original = compiled(system)
    assert [p.name for p in original.components[0].interface.ports] == ["t", "p"]
    for other in (compiled(archive), compiled(back)):
        assert fingerprint(other) == fingerprint(original)
    assert back.read_text(encoding="utf-8").index("t:") < back.read_text(encoding="utf-8").index(
        "p:"
    )
