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
