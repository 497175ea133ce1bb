"""A lone model compiles to the same system without the system-file types (issue #14).

``fmionnx run model.fmu`` compiles the model through :func:`fmionnx.compile.lone.compile_lone`
instead of building a one-component ``SystemSpec`` for ``compile_spec``. Both are run here on
the same models and settings: the compiled systems, their serialised form (``fmionnx
compile``'s file), their diagnostics, their results and their ``run.json`` must be the same.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.lone import compile_lone
from fmionnx.compile.single import _component_name
from fmionnx.compile.systemfile import to_json
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.spec.runspec import RunSpec

LONE_WARNINGS = ("W030", "W050")  # what compile/single.py drops for a model alone


def via_system_file(
    path: Path, spec: ComponentSpecBase, run: RunSpec
) -> tuple[CompiledSystem | None, list[Diagnostic]]:
    """The former way: a one-component SystemSpec through the system-file compiler."""
    from fmionnx.compile.compiler import compile_spec
    from fmionnx.spec.model import SystemSpec
    from fmionnx.spec.sourcemap import SourceMap
    from fmionnx.spec.yaml import LoadedSpec

    name = _component_name(path)
    system = SystemSpec(fmionnx=1, name=name, run=run, components={name: spec})
    bag = DiagnosticBag()
    compiled = compile_spec(LoadedSpec(system, SourceMap(path), path), bag)
    return compiled, [d for d in bag if d.code not in LONE_WARNINGS]


def alone(
    path: Path, spec: ComponentSpecBase, run: RunSpec
) -> tuple[CompiledSystem | None, list[Diagnostic]]:
    bag = DiagnosticBag()
    compiled = compile_lone(_component_name(path), spec, run, path, bag)
    return compiled, [d for d in bag if d.code not in LONE_WARNINGS]


def assert_same(path: Path, spec: ComponentSpecBase, run: RunSpec) -> CompiledSystem | None:
    expected, expected_diagnostics = via_system_file(path, spec, run)
    got, diagnostics = alone(path, spec, run)
    assert diagnostics == expected_diagnostics
    assert got == expected
    if got is not None and expected is not None:
        assert to_json(got) == to_json(expected)
        assert got.content_hash == expected.content_hash
    return got


def fmu_spec(path: Path, **fields: Any) -> ComponentSpecBase:
    from fmionnx.kinds.fmu.spec import FmuSpec

    return FmuSpec(path=str(path.resolve()), **fields)


@pytest.fixture
def copy_fmu(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Callable[[str], Path]:
    def copy(name: str) -> Path:
        target = tmp_path / f"{name}.fmu"
        shutil.copy(fixture_fmu(name), target)
        return target

    return copy


@pytest.mark.parametrize("name", ["Gain", "Integrator", "Vector3", "Count2", "Scale3", "Types3"])
def test_every_fixture_fmu_compiles_alone_as_in_a_system_file(
    copy_fmu: Callable[[str], Path], name: str
) -> None:
    """Each with its own default experiment (or the error of having none)."""
    path = copy_fmu(name)
    assert_same(path, fmu_spec(path), RunSpec(start=0.0))


@pytest.mark.parametrize(
    ("fields", "run"),
    [
        ({}, RunSpec(step=0.01, start=1.5)),
        ({"interface": "me"}, RunSpec(step=0.01)),
        ({"interface": "cs"}, RunSpec(step=0.25, stop=1.0)),
        ({"parameters": {"k": 3.0}}, RunSpec(step=0.01)),  # Gain's k; Integrator: no such
        ({"period": 0.03}, RunSpec(step=0.02)),  # not a whole multiple: E041
        ({}, RunSpec(step=0.3, stop=0.1)),  # a step longer than the run
        ({}, RunSpec(start=2.0, stop=1.0)),  # stop before start
    ],
)
@pytest.mark.parametrize("name", ["Gain", "Integrator"])
def test_settings_and_their_errors_are_the_same(
    copy_fmu: Callable[[str], Path], name: str, fields: dict[str, Any], run: RunSpec
) -> None:
    path = copy_fmu(name)
    assert_same(path, fmu_spec(path, **fields), run)


def test_an_onnx_model_compiles_alone_as_in_a_system_file(tmp_path: Path) -> None:
    onnx = pytest.importorskip("onnx")
    from fmionnx.kinds.onnx.spec import OnnxSpec
    from tests.fixtures.onnx.build_models import scale

    path = tmp_path / "scale.onnx"
    onnx.save(scale(), path)
    spec = OnnxSpec(path=str(path.resolve()))
    assert assert_same(path, spec, RunSpec(start=0.0, stop=1.0, step=1.0)) is not None


def test_results_and_run_json_are_the_same(tmp_path: Path, copy_fmu: Callable[[str], Path]) -> None:
    from fmionnx.api import System
    from fmionnx.core.types import Causality, PortRef
    from fmionnx.kinds.registry import result_aliases
    from fmionnx.results import write_results

    path = copy_fmu("Integrator")
    spec, run = fmu_spec(path), RunSpec(step=0.01, start=0.5)
    written = {}
    for label, compile_with in (("file", via_system_file), ("alone", alone)):
        compiled, _ = compile_with(path, spec, run)
        assert compiled is not None
        component = compiled.components[0]
        refs = tuple(
            PortRef(component.name, p.name)
            for p in component.interface.with_causality(Causality.OUTPUT)
        )
        system = System(compiled, (), result_aliases(component), refs)
        result = system.run(isolate="none", stop_time=2.5, params={"u": 2.0})
        out = tmp_path / label
        write_results(result, system.compiled, out, aliases=dict(system.aliases))
        info = json.loads((out / "run.json").read_text(encoding="utf-8"))
        for volatile in ("wall_time", "real_time_factor"):
            info.pop(volatile)
        written[label] = ((out / "results.csv").read_bytes(), info)
    assert written["alone"] == written["file"]
    last = written["alone"][0].splitlines()[-1].split(b",")
    assert last[0] == b"2.5"
    assert float(last[1]) == pytest.approx(4.0, abs=1e-9)  # x = u * (2.5 - 0.5), u = 2


def test_an_error_is_reported_alone_as_in_a_system_file(copy_fmu: Callable[[str], Path]) -> None:
    path = copy_fmu("Gain")
    compiled, diagnostics = alone(path, fmu_spec(path, period=0.03), RunSpec(step=0.02))
    assert compiled is None
    assert [d.code for d in diagnostics] == ["E041"]
    assert "not a whole multiple of the base step 0.02" in diagnostics[0].message


@pytest.mark.parametrize(
    ("file", "content"),
    [
        ("table.csv", "time,a,b\n0,1,2\n0.5,3,4\n1,5,6\n"),
        ("bad.csv", "time,a\n0,1\n1,x\n"),  # an error at the table's line
        ("rover.xml", None),  # the fixture MuJoCo scene
    ],
)
def test_other_models_validate_alone_as_in_a_system_file(
    tmp_path: Path, file: str, content: str | None
) -> None:
    """``fmionnx validate`` compiles any model a kind reads: a signal table, a scene."""
    from fmionnx.kinds.registry import kind_for_path
    from tests.conftest import REPO

    path = tmp_path / file
    if content is None:
        shutil.copy(REPO / "tests" / "fixtures" / "scenes" / file, path)
    else:
        path.write_text(content, encoding="utf-8")
    kind = kind_for_path(path)
    assert kind is not None
    spec = kind.spec_model.model_validate({"path": str(path.resolve())})
    assert_same(path, spec, RunSpec(start=0.0, stop=0.5, step=0.5))
