"""YAML -> SSP -> YAML gives the same compiled system hash, order of entries included.

The compiled hash covers the order of a component's parameters and of the system inputs, so
a round trip must give them back as written: parameters split between the ``.ssv`` and our
annotation, and system inputs that are open, hold a value of their own, or hold a value that
reaches ports. SSD files of other tools carry no annotation: there a bound root connector stays
a value flowing to the ports it reaches, and the inputs follow the connectors' declarations.
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

import fmionnx
from fmionnx.compile.ir import CompiledSystem
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.types import PortRef
from fmionnx.spec.frontends import load_system
from tests.conftest import REPO, cli
from tests.ssp.conftest import write_ssp
from tests.ssp.test_roundtrip import compiled, round_trip
from tests.ssp.test_system_connectors import TOP_SSM, TOP_SSV, top_ssd

FixtureFmu = Callable[[str], Path]


def _inputs(system: CompiledSystem) -> list[tuple[str, object, list[tuple[str, float, float]]]]:
    return [
        (i.name, i.value, [(str(t.ref), t.factor, t.offset) for t in i.targets])
        for i in system.inputs
    ]


def _parameters(system: CompiledSystem) -> list[tuple[str, list[str]]]:
    return [(c.name, [p.port for p in c.parameters]) for c in system.components]


def _assert_same_compiled_system(system: Path, folder: Path) -> tuple[Path, Path]:
    archive, back = round_trip(system, folder)
    original = compiled(system)
    for other in (compiled(archive), compiled(back)):
        assert _parameters(other) == _parameters(original)
        assert _inputs(other) == _inputs(original)
        assert other.content_hash == original.content_hash
    return archive, back


def test_the_reference_system_round_trips_to_the_same_compiled_hash(tmp_path: Path) -> None:
    _assert_same_compiled_system(REPO / "systems" / "sign_follower.yaml", tmp_path)


def test_parameters_from_the_ssv_and_the_annotation_keep_their_order(
    tmp_path: Path, fixture_fmu: FixtureFmu
) -> None:
    """`k` goes into the `.ssv`, the array `v` into the annotation: both back as written."""
    system = tmp_path / "params.yaml"
    system.write_text(
        "fmionnx: 1\nname: params\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fixture_fmu('Gain')}, "
        "parameters: {k: 2.0, v: [1.0, 2.0, 3.0]}}\n"
        f"  t: {{kind: fmu, path: {fixture_fmu('Types3')}, "
        "parameters: {u_i32: -7, u_i64: 3000000000, u_f32: 1.5}}\n",
        encoding="utf-8",
    )
    archive, _ = _assert_same_compiled_system(system, tmp_path)
    assert _parameters(compiled(archive)) == [("a", ["k", "v"]), ("t", ["u_i32", "u_i64", "u_f32"])]


def test_open_and_valued_system_inputs_keep_their_order_values_and_targets(
    tmp_path: Path, fixture_fmu: FixtureFmu
) -> None:
    """Open inputs, inputs with a value and ports, and inputs holding only a value, mixed."""
    system = tmp_path / "inputs.yaml"
    system.write_text(
        "fmionnx: 1\nname: inputs\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{u: 0.5}}}}\n"
        f"  b: {{kind: fmu, path: {fixture_fmu('Integrator')}}}\n"
        "inputs:\n"
        "  drive: {to: [b.u]}\n"
        "  gain: {to: [{to: a.k, factor: 2.0, offset: 0.5}], value: 1.5}\n"
        "  spare: {to: [], value: -20}\n"
        "  huge: {to: [], value: 9000000000}\n"
        "  start: {to: [b.x0], value: 0.25}\n"
        "  rate: {to: [b.xStop]}\n",
        encoding="utf-8",
    )
    archive, _ = _assert_same_compiled_system(system, tmp_path)
    assert _inputs(compiled(archive)) == [
        ("drive", None, [("b.u", 1.0, 0.0)]),
        ("gain", 1.5, [("a.k", 2.0, 0.5)]),
        ("spare", -20, []),
        ("huge", 9000000000, []),
        ("start", 0.25, [("b.x0", 1.0, 0.0)]),
        ("rate", None, [("b.xStop", 1.0, 0.0)]),
    ]
    back = fmionnx.load(archive).with_overrides(params={"gain": 3.0})
    assert next(p.value for p in back.compiled.component("a").parameters if p.port == "k") == (6.5,)


def test_an_integer_value_on_real_targets_is_bound_as_an_ssv_real(
    tmp_path: Path, fixture_fmu: FixtureFmu
) -> None:
    """libcosim refuses an ssv:Integer for a Real: the targets' type decides, as for parameters."""
    system = tmp_path / "gain.yaml"
    system.write_text(
        "fmionnx: 1\nname: gain\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        f"  t: {{kind: fmu, path: {fixture_fmu('Types3')}}}\n"
        "inputs:\n  gain: {to: [a.k], value: 3}\n  count: {to: [t.u_i32], value: 4}\n",
        encoding="utf-8",
    )
    archive, back = _assert_same_compiled_system(system, tmp_path)
    with zipfile.ZipFile(archive) as members:
        ssd = members.read("SystemStructure.ssd").decode()
    gain = ssd.split('<ssv:Parameter name="gain">', 1)[1].split("</ssv:Parameter>", 1)[0]
    count = ssd.split('<ssv:Parameter name="count">', 1)[1].split("</ssv:Parameter>", 1)[0]
    assert '<ssv:Real value="3.0"/>' in gain
    assert '<ssv:Integer value="4"/>' in count
    for other in (compiled(archive), compiled(back)):
        assert [(i.name, i.value) for i in other.inputs] == [("gain", 3.0), ("count", 4)]
        assert [p.value for p in other.component("a").parameters] == [(3.0,)]


def test_a_whole_number_for_a_real_parameter_round_trips_to_the_same_hash(
    tmp_path: Path, fixture_fmu: FixtureFmu
) -> None:
    """SSP has no integer form of a Real: `k: 3` came back `3.0`, another compiled hash. A
    whole number for a float port compiles as the float, as `--param` gives it."""
    system = tmp_path / "whole.yaml"
    system.write_text(
        "fmionnx: 1\nname: whole\nrun: {stop: 0.1, step: 0.01}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{k: 3, v: [1, 2, 3]}}}}\n",
        encoding="utf-8",
    )
    _assert_same_compiled_system(system, tmp_path)
    assert [p.value for p in compiled(system).component("a").parameters] == [
        (3.0,),
        (1.0, 2.0, 3.0),
    ]
    assert all(
        type(v) is float for p in compiled(system).component("a").parameters for v in p.value
    )


def _with_annotation(ssd: str, payload: str) -> str:
    annotation = (
        '<ssd:Annotations><ssc:Annotation type="org.fmionnx">'
        f'<fmionnx:Options xmlns:fmionnx="https://fmionnx.dev/ssp/1">{payload}</fmionnx:Options>'
        "</ssc:Annotation></ssd:Annotations>\n"
    )
    return ssd.replace(
        "</ssd:SystemStructureDescription>", annotation + "</ssd:SystemStructureDescription>"
    )


def _foreign(folder: Path, fixture_fmu: FixtureFmu, ssd: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    return write_ssp(
        folder / "top.ssp",
        {
            "SystemStructure.ssd": ssd,
            "resources/Gain.fmu": fixture_fmu("Gain"),
            "resources/Integrator.fmu": fixture_fmu("Integrator"),
            "resources/top.ssv": TOP_SSV,
            "resources/top.ssm": TOP_SSM,
        },
    )


def test_a_foreign_ssds_inputs_follow_the_declared_connectors(
    tmp_path: Path, fixture_fmu: FixtureFmu
) -> None:
    """Connectors drive, k_top, gain_k (in that order) are connected in another order."""
    system = compiled(_foreign(tmp_path, fixture_fmu, top_ssd(binding="")))
    assert [i.name for i in system.inputs] == ["drive", "k_top", "gain_k"]


def test_only_our_annotation_keeps_a_bound_root_connector_an_input(
    tmp_path: Path, fixture_fmu: FixtureFmu
) -> None:
    """Another tool's bound connector is a value for the ports it reaches; named in
    `bound_inputs`, it is a system input with that value. The ports get the same values."""
    theirs = compiled(_foreign(tmp_path / "theirs", fixture_fmu, top_ssd()))
    ssd = _with_annotation(top_ssd(), '{"bound_inputs": ["gain_k", "drive"]}')
    ours = compiled(_foreign(tmp_path / "ours", fixture_fmu, ssd))
    assert theirs.inputs == ()
    assert _inputs(ours) == [
        ("drive", 4.0, [("integ.u", 0.5, 0.0)]),
        ("gain_k", 3.0, [("gain1.k", 1.0, 0.0)]),
    ]
    record = (PortRef("integ", "x"), PortRef("sub.gain2", "y"))
    runs = [
        fmionnx.load(path).run(isolate="none", signals=record)
        for path in (tmp_path / "theirs" / "top.ssp", tmp_path / "ours" / "top.ssp")
    ]
    for name in ("integ.x", "sub.gain2.y"):
        assert runs[0][name][-1] == pytest.approx(runs[1][name][-1])
    assert runs[0]["integ.x"][-1] == pytest.approx(2.0)  # drive = 4, integ.u = 0.5 * 4


@pytest.mark.parametrize(
    ("where", "payload"),
    [("system", '{"bound_inputs": "drive"}'), ("component", '{"parameter_order": "k"}')],
)
def test_a_malformed_order_in_our_annotation_is_an_error(
    tmp_path: Path, fixture_fmu: FixtureFmu, where: str, payload: str
) -> None:
    ssd = top_ssd()
    if where == "system":
        ssd = _with_annotation(ssd, payload)
    else:
        ssd = ssd.replace(
            "</ssd:Connectors></ssd:Component>",
            '</ssd:Connectors><ssd:Annotations><ssc:Annotation type="org.fmionnx">'
            f'<fmionnx:Options xmlns:fmionnx="https://fmionnx.dev/ssp/1">{payload}'
            "</fmionnx:Options></ssc:Annotation></ssd:Annotations></ssd:Component>",
            1,
        )
    archive = _foreign(tmp_path, fixture_fmu, ssd)
    bag = DiagnosticBag()
    assert load_system(archive, bag).spec is None
    found = [d for d in bag if d.code == codes.INVALID_VALUE.code]
    assert len(found) == 1, [d.message for d in bag]
    assert "must list" in found[0].message
    assert found[0].span is not None
    assert found[0].span.line is not None
    assert found[0].span.line > 1
    code, output = cli("validate", str(archive))
    assert code == 1
    assert "must list" in output
