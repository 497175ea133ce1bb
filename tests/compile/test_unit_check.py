"""Units on connections: converted by definition (I033), different quantities (E033), the
explicit and suppressed cases (W033), and the conversion kept in the compiled system."""

from __future__ import annotations

import math
import os
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper
from typer.testing import CliRunner

from fmionnx import api
from fmionnx.cli.app import app
from fmionnx.compile.endpoints import ResolvedEndpoint
from fmionnx.compile.ir import CompiledSystem, Connection
from fmionnx.compile.systemfile import from_json, to_json
from fmionnx.compile.unitcheck import Transform, check_units
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.types import Causality, DType, Port, PortRef
from fmionnx.core.units import BUILTIN_UNITS, Unit, UnitConversion, builtin_unit

GOLDEN = Path(__file__).resolve().parent / "golden" / "units.txt"
BUILTIN_M = BUILTIN_UNITS["m"]
PORTS = "abcdefgh"


def write_identity_onnx(path: Path, names: str = PORTS) -> Path:
    """``y_i = x_i`` for every name: float64 [1] tensors, so values pass unrounded."""
    nodes = [helper.make_node("Identity", [f"x_{n}"], [f"y_{n}"]) for n in names]
    inputs = [helper.make_tensor_value_info(f"x_{n}", TensorProto.DOUBLE, [1]) for n in names]
    outputs = [helper.make_tensor_value_info(f"y_{n}", TensorProto.DOUBLE, [1]) for n in names]
    graph = helper.make_graph(nodes, "identity", inputs, outputs)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


INVALID = """\
fmionnx: 1
name: units
run: {stop: 0.1, step: 0.01}
components:
  sig:
    kind: signal
    outputs:
      speed: {constant: 90, unit: km/h}
      temp: {constant: 20, unit: degC}
      len: {constant: 1, unit: m}
      col: {constant: 3, unit: px}
      len2: {constant: 1, unit: m}
      kmh: {constant: 90, unit: km/h}
      bare: {constant: 1}
      ms: {constant: 1, unit: m/s}
  net:
    kind: onnx
    path: identity.onnx
    units: {x_a: m/s, x_b: K, x_c: s, x_d: m, x_e: s, x_f: m/s, x_g: m/s, x_h: m/s}
connections:
  - sig.speed -> net.x_a
  - sig.temp -> net.x_b
  - sig.len -> net.x_c
  - sig.col -> net.x_d
  - {from: sig.len2, to: net.x_e, convert_units: false}
  - {from: sig.kmh, to: net.x_f, factor: 0.2777777777777778, convert_units: false}
  - sig.bare -> net.x_g
  - sig.ms -> net.x_h
"""

VALID = """\
fmionnx: 1
name: units
run: {stop: 0.1, step: 0.01}
components:
  sig:
    kind: signal
    outputs:
      speed: {constant: 90, unit: km/h}
      temp: {constant: 20, unit: degC}
      angle: {constant: 180, unit: deg}
      scaled: {constant: 36, unit: km/h}
      bare: {constant: 1}
      ms: {constant: 1, unit: m/s}
  net:
    kind: onnx
    path: identity.onnx
    units: {x_a: m/s, x_b: K, x_c: rad, x_d: m/s, x_e: m/s, x_f: m/s}
connections:
  - sig.speed -> net.x_a
  - sig.temp -> net.x_b
  - sig.angle -> net.x_c
  - {from: sig.scaled, to: net.x_d, factor: 2, offset: 1}
  - sig.bare -> net.x_e
  - sig.ms -> net.x_f
"""


def _system(tmp_path: Path, text: str) -> Path:
    write_identity_onnx(tmp_path / "identity.onnx")
    path = tmp_path / "system.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _compiled(tmp_path: Path) -> CompiledSystem:
    result = api.compile_system(_system(tmp_path, VALID))
    assert result.system is not None, [str(d) for d in result.diagnostics]
    return result.system


def _connection(system: CompiledSystem, port: str) -> Connection:
    return next(c for c in system.connections if c.dst.port == port)


def test_validate_reports_conversions_and_mismatches_with_positions(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _system(tmp_path, INVALID)
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(app, ["validate", "system.yaml"], env={"COLUMNS": "200"})
    assert "Traceback" not in result.output
    assert result.exit_code == 1
    if os.environ.get("UPDATE_GOLDEN") == "1":
        GOLDEN.write_text(result.output, encoding="utf-8")
    assert result.output == GOLDEN.read_text(encoding="utf-8")


def test_compatible_units_are_converted_by_the_connection(tmp_path: Path) -> None:
    system = _compiled(tmp_path)
    speed = _connection(system, "x_a")
    assert speed.units == UnitConversion("km/h", "m/s", speed.factor, 0.0)
    assert 90.0 * speed.factor + speed.offset == pytest.approx(25.0, rel=1e-15)
    temp = _connection(system, "x_b")
    assert (temp.factor, temp.offset) == (1.0, 273.15)
    angle = _connection(system, "x_c")
    assert 180.0 * angle.factor + angle.offset == pytest.approx(math.pi, rel=1e-15)


def test_the_connections_factor_and_offset_apply_after_the_conversion(tmp_path: Path) -> None:
    # 36 km/h = 10 m/s, then y = 2*x + 1 in m/s: 21 m/s.
    scaled = _connection(_compiled(tmp_path), "x_d")
    assert scaled.units is not None
    assert 36.0 * scaled.factor + scaled.offset == pytest.approx(21.0, rel=1e-15)


def test_no_unit_or_equal_units_convert_nothing(tmp_path: Path) -> None:
    system = _compiled(tmp_path)
    for port in ("x_e", "x_f"):
        connection = _connection(system, port)
        assert (connection.units, connection.factor, connection.offset) == (None, 1.0, 0.0)


def test_the_valid_system_passes_with_notes_only(tmp_path: Path) -> None:
    result = api.compile_system(_system(tmp_path, VALID))
    codes = sorted(d.code for d in result.diagnostics if d.code.endswith("033"))
    assert codes == ["I033"] * 4  # km/h, degC, deg and the scaled km/h; not `bare`, not `ms`
    assert result.system is not None


def test_units_and_definitions_round_trip_through_the_compiled_file(tmp_path: Path) -> None:
    system = _compiled(tmp_path)
    back = from_json(to_json(system))
    assert back == system
    port = back.component("net").interface.port("x_a")
    assert port is not None
    assert port.unit == "m/s"
    assert port.unit_definition is not None
    assert port.unit_definition.exponents == (0, 1, -1, 0, 0, 0, 0, 0)
    assert _connection(back, "x_a").units == _connection(system, "x_a").units


def test_onnx_units_naming_no_port_is_e018(tmp_path: Path) -> None:
    text = VALID.replace("x_f: m/s}", "x_f: m/s, x_z: m}")
    result = api.compile_system(_system(tmp_path, text))
    found = [d for d in result.diagnostics if d.code == "E018"]
    assert len(found) == 1
    assert "no port `x_z`" in found[0].message
    assert found[0].span is not None
    assert found[0].span.line == 17


def _end(
    component: str, unit: str | None, *, relative: bool = False, definition: bool = True
) -> ResolvedEndpoint:
    port = Port(
        "p",
        Causality.OUTPUT if component == "a" else Causality.INPUT,
        DType.FLOAT64,
        unit=unit,
        unit_definition=builtin_unit(unit) if definition else None,
        relative_quantity=relative,
    )
    return ResolvedEndpoint(PortRef(component, "p"), port, 1)


def _check(
    src: ResolvedEndpoint, dst: ResolvedEndpoint, factor: float = 1.0
) -> tuple[Transform | None, list[tuple[str, str]]]:
    bag = DiagnosticBag()
    transform = check_units(src, dst, Span(Path("s.yaml"), 1, 1), bag, factor=factor)
    return transform, [(d.code, d.message) for d in bag]


def test_a_relative_quantity_on_either_end_converts_without_offset() -> None:
    for src_relative, dst_relative in ((True, False), (False, True), (True, True)):
        transform, found = _check(
            _end("a", "degC", relative=src_relative), _end("b", "K", relative=dst_relative)
        )
        assert transform is not None
        assert (transform.factor, transform.offset) == (1.0, 0.0)
        assert [code for code, _ in found] == []  # nothing is converted: no note
    transform, found = _check(_end("a", "degF", relative=True), _end("b", "K"))
    assert transform is not None
    assert transform.factor == pytest.approx(5.0 / 9.0)
    assert transform.offset == 0.0
    assert "relative quantity: offsets ignored" in found[0][1]


def test_names_without_definitions_compare_as_text() -> None:
    same, found = _check(_end("a", "px", definition=False), _end("b", "px", definition=False))
    assert same is not None
    assert found == []
    _, found = _check(_end("a", "px", definition=False), _end("b", "m"))
    assert [code for code, _ in found] == ["E033"]
    explicit, found = _check(_end("a", "px", definition=False), _end("b", "m"), factor=0.001)
    assert explicit is not None
    assert (explicit.factor, found) == (0.001, [])


def test_an_explicit_factor_that_repeats_the_conversion_warns() -> None:
    transform, found = _check(_end("a", "km/h"), _end("b", "m/s"), factor=1 / 3.6)
    assert transform is not None
    assert sorted(code for code, _ in found) == ["I033", "W033"]
    assert transform.factor == pytest.approx(1 / 3.6**2)


def test_a_port_without_unit_connects_to_anything() -> None:
    for src, dst in ((_end("a", None), _end("b", "m")), (_end("a", "m"), _end("b", None))):
        transform, found = _check(src, dst)
        assert transform is not None
        assert (transform.units, transform.factor, transform.offset, found) == (
            None,
            1.0,
            0.0,
            [],
        )


def test_the_graph_labels_an_edge_with_its_unit_conversion(tmp_path: Path) -> None:
    from fmionnx.export.graph import to_dot

    dot = to_dot(_compiled(tmp_path))
    assert "speed → x_a (km/h → m/s)" in dot
    assert "bare → x_e\\l" in dot  # no unit, no conversion: the label is unchanged


def test_equal_names_with_different_definitions_convert_by_definition() -> None:
    odd = Port(
        "p",
        Causality.OUTPUT,
        DType.FLOAT64,
        unit="m",
        unit_definition=Unit("m", BUILTIN_M.exponents, 0.001),
    )
    transform, found = _check(ResolvedEndpoint(PortRef("a", "p"), odd, 1), _end("b", "m"))
    assert transform is not None
    assert transform.factor == pytest.approx(0.001)
    assert [code for code, _ in found] == ["I033"]
    assert "same name, different definitions" in found[0][1]
    # Equal definitions under different names convert nothing and say nothing.
    transform, found = _check(_end("a", "N.m"), _end("b", "J"))
    assert (transform, found) == (Transform(None, 1.0, 0.0), [])
