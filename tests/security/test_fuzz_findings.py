"""The inputs the fuzzers (tests/fuzz) found to escape as tracebacks, each pinned: every one
now ends in a diagnostic with a code, or a clean fault."""

from __future__ import annotations

import struct
import zipfile
from pathlib import Path

import pytest

import fmionnx
from fmionnx import api
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.errors import DiagnosticError, ModelError
from fmionnx.kinds.fmu.kind import FMU_KIND
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.yaml import parse_yaml
from tests.conftest import build_fixture_fmu


def _yaml_problems(text: str, tmp_path: Path) -> list[tuple[str, str]]:
    path = tmp_path / "system.yaml"
    bag = DiagnosticBag()
    assert parse_yaml(text, path, SourceMap(path), bag) is None
    return [(d.code, str(d.message)) for d in bag.sorted()]


@pytest.mark.parametrize(
    ("text", "code", "words"),
    [
        ("components:\n  <<: {a: 1}\n", "E003", "merge keys"),
        ("<<: {run: {stop: 1}}\nfmionnx: 1\n", "E003", "merge keys"),
        ("&a [*a]\n", "E003", "contains itself"),
        ("&m {a: *m}\n", "E003", "contains itself"),
        ("? b: {c: 1}\n: x\n", "E001", "key is itself a mapping"),
        # found by fuzzing study files: ruamel's set constructor fails on a scalar
        ("!!set fmionnx: 1\nname: x\n", "E001", "a tag does not fit"),
        ("fmionnx: 1\nrun: {stop: !!set 1}\n", "E001", "a tag does not fit"),
        ("fmionnx: 1\ndescription: 2020-02-30\n", "E001", "cannot build: day is out of range"),
    ],
)
def test_yaml_structures_a_system_file_cannot_hold_are_diagnostics(
    tmp_path: Path, text: str, code: str, words: str
) -> None:
    problems = _yaml_problems(text, tmp_path)
    assert len(problems) == 1
    assert problems[0][0] == code
    assert words in problems[0][1]


def test_a_tag_that_does_not_fit_is_shown_where_it_is(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    bag = DiagnosticBag()
    parse_yaml("fmionnx: 1\nrun: {stop: !!set 1}\n", path, SourceMap(path), bag)
    [problem] = bag.sorted()
    assert problem.span is not None
    assert (problem.span.line, problem.span.col) == (2, 13)


def _damaged(tmp_path: Path, damage: str) -> Path:
    """A copy of a real FMU with one kind of damage the fuzzers found."""
    data = bytearray(build_fixture_fmu("Gain").read_bytes())
    with zipfile.ZipFile(build_fixture_fmu("Gain")) as archive:
        info = archive.getinfo("modelDescription.xml")
    local = info.header_offset
    name_length, extra_length = struct.unpack_from("<HH", data, local + 26)
    start = local + 30 + name_length + extra_length
    if damage == "deflate":
        data[start] = 0xFF  # a reserved deflate block type
    elif damage == "encrypted":
        central = data.rfind(b"PK\x01\x02", 0)
        while central >= 0:  # set the flag on every central-directory entry
            flags = struct.unpack_from("<H", data, central + 8)[0]
            struct.pack_into("<H", data, central + 8, flags | 1)
            central = data.rfind(b"PK\x01\x02", 0, central)
    elif damage == "version":
        central = data.find(b"PK\x01\x02")
        while central >= 0:
            struct.pack_into("<H", data, central + 6, 200)
            central = data.find(b"PK\x01\x02", central + 4)
    path = tmp_path / f"damaged-{damage}.fmu"
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize("damage", ["deflate", "encrypted", "version"])
def test_a_damaged_fmu_zip_is_e012(tmp_path: Path, damage: str) -> None:
    with pytest.raises(ModelError) as info:
        FMU_KIND.read_interface(_damaged(tmp_path, damage), None)
    assert info.value.code is codes.BAD_MODEL


def test_a_model_path_longer_than_the_file_system_allows_is_e010(tmp_path: Path) -> None:
    system = tmp_path / "system.yaml"
    system.write_text(
        f"fmionnx: 1\nname: long\nrun: {{stop: 1, step: 0.1}}\n"
        f"components:\n  a: {{kind: fmu, path: {'x' * 300}.fmu}}\n",
        encoding="utf-8",
    )
    with pytest.raises(DiagnosticError) as info:
        fmionnx.load(system)
    assert [d.code for d in info.value.diagnostics] == ["E010"]
    assert "cannot be read" in str(info.value.diagnostics[0].message)


def test_a_sine_too_fast_to_sample_is_refused_at_compile_time(tmp_path: Path) -> None:
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: fast\nrun: {stop: 1, step: 0.1}\n"
        "components:\n  s: {kind: signal, outputs: {y: {sine: {frequency: 1e308}}}}\n",
        encoding="utf-8",
    )
    with pytest.raises(DiagnosticError) as info:
        fmionnx.load(system)
    assert "1000000000000" in str(info.value.diagnostics[0].message)


@pytest.mark.parametrize("isolate", ["fmus", "none"])
def test_an_fmu_whose_library_cannot_be_unpacked_is_a_fault_naming_it(
    tmp_path: Path, isolate: str
) -> None:
    from typer.testing import CliRunner

    from fmionnx.cli import app

    data = bytearray(build_fixture_fmu("Gain").read_bytes())
    central = data.find(b"PK\x01\x02")
    while central >= 0:  # the shared library's entry says it is encrypted
        length = struct.unpack_from("<H", data, central + 28)[0]
        if bytes(data[central + 46 : central + 46 + length]).endswith(b".so"):
            flags = struct.unpack_from("<H", data, central + 8)[0]
            struct.pack_into("<H", data, central + 8, flags | 1)
        central = data.find(b"PK\x01\x02", central + 4)
    fmu = tmp_path / "locked.fmu"
    fmu.write_bytes(bytes(data))
    result = CliRunner().invoke(
        app, ["run", str(fmu), "--stop-time", "0.1", "--no-out", "--isolate", isolate]
    )
    assert result.exit_code == 1, result.output
    assert "component `locked` at t=0 s:" in result.output
    assert "encrypted" in result.output
    assert "Traceback" not in result.output


def test_a_ros2_field_list_must_name_a_field(tmp_path: Path) -> None:
    """``field: []`` reached the ROS 2 plan and failed there with an IndexError."""
    system = tmp_path / "system.yaml"
    system.write_text(
        f"fmionnx: 1\nname: x\ncomponents:\n  g: {{kind: fmu, path: {build_fixture_fmu('Gain')}}}\n"
        "ros2:\n  topics:\n    g.y: {topic: /y, type: std_msgs/msg/Float64MultiArray, field: []}\n",
        encoding="utf-8",
    )
    result = api.compile_system(system)
    [problem] = [d for d in result.diagnostics if d.code == "E003"]
    assert "`ros2.topics.g.y.field`: List should have at least 1 item" in problem.message
    assert problem.span is not None
    assert problem.span.line == 7


def test_a_reused_anchor_is_read_without_a_library_warning(tmp_path: Path) -> None:
    """YAML lets a later anchor replace an earlier one; ruamel printed a Python warning with
    its own source line on stderr (an error under this suite's warning filter)."""
    path = tmp_path / "system.yaml"
    bag = DiagnosticBag()
    data = parse_yaml("fmionnx: 1\nx: [&a [1], &a [2], *a]\n", path, SourceMap(path), bag)
    assert data == {"fmionnx": 1, "x": [[1], [2], [2]]}
    assert not bag.sorted()


def test_a_model_path_of_no_users_home_is_not_found(tmp_path: Path) -> None:
    """``~name/...`` expands to that user's home; of no user, Python raised RuntimeError."""
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: x\ncomponents:\n  g: {kind: fmu, path: ~no-such-user-here/Gain.fmu}\n",
        encoding="utf-8",
    )
    result = api.compile_system(system)
    [problem] = [d for d in result.diagnostics if d.code == "E010"]
    assert problem.message.endswith("/~no-such-user-here/Gain.fmu` does not exist")


def test_a_scene_whose_arena_is_too_small_is_a_fault_naming_it(tmp_path: Path) -> None:
    # found by fuzzing scenes (issue 38): `<size memory="11650"/>` compiles, then MuJoCo's
    # first forward pass raised mujoco.FatalError out of the run (a traceback).
    (tmp_path / "scene.xml").write_text(
        '<mujoco><size memory="11650"/><asset><hfield name="ground" nrow="8" ncol="8" '
        'size="1 1 0.1 0.1"/></asset><worldbody><geom type="hfield" hfield="ground"/>'
        '<replicate count="3" offset="0.3 0 0"><body pos="0 0 0.5"><joint type="hinge"/>'
        '<geom size="0.05"/></body></replicate>'
        '<flexcomp name="cloth" type="grid" count="2 2 1" spacing="0.1 0.1 0.1" dim="2" '
        'pos="1 1 1"/><body pos="0 0 1"><freejoint/><geom size="0.1"/></body>'
        "</worldbody></mujoco>",
        "utf-8",
    )
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: tiny\nrun: {stop: 0.01, step: 0.002}\n"
        "components:\n  world: {kind: mujoco, path: scene.xml}\n",
        "utf-8",
    )
    result = fmionnx.load(system).run()
    assert result.status.value == "fault"
    assert result.error is not None
    assert "MuJoCo stopped: mj_stackAlloc: out of memory" in str(result.error)
    assert "raise the scene's `<size memory>`" in str(result.error)


def test_a_scene_memory_of_thousands_of_digits_is_e008(tmp_path: Path) -> None:
    # found by fuzzing scenes (issue 38): Python refuses to read an integer of more than 4300
    # digits (a ValueError, a traceback)
    path = tmp_path / "scene.xml"
    path.write_text(
        f'<mujoco><size memory="1{"0" * 5000}"/><worldbody><geom size="1"/></worldbody></mujoco>',
        "utf-8",
    )
    result = api.check_model(path)
    (error,) = [d for d in result.diagnostics if d.code == "E008"]
    assert "takes the scene's memory to" in error.message


def _onnx_model(path: Path, output_shape: list[int], expand_to: list[int]) -> Path:
    """``y = Expand(x, expand_to)`` with ``y`` declared as ``double[output_shape]``."""
    from onnx import TensorProto, helper

    shape = helper.make_tensor("s", TensorProto.INT64, [len(expand_to)], expand_to)
    graph = helper.make_graph(
        [
            helper.make_node("Constant", [], ["shape"], value=shape),
            helper.make_node("Expand", ["x", "shape"], ["y"]),
        ],
        "expand",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, [1])],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, output_shape)],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    path.write_bytes(model.SerializeToString())
    return path


def test_an_output_of_another_shape_than_declared_is_a_fault_naming_it(tmp_path: Path) -> None:
    # found by fuzzing models (issue 38): an output declared double[1] that the model expands
    # to 3 elements compiled, then the run crashed where it was first recorded (a numpy
    # ValueError, a traceback)
    model = _onnx_model(tmp_path / "expand.onnx", [1], [3])
    path = tmp_path / "expand.yaml"  # run over time (a lone model is inferred once)
    path.write_text(
        f"fmionnx: 1\nname: expand\nrun: {{stop: 2, step: 1}}\n"
        f"components:\n  expand: {{kind: onnx, path: {model}}}\n",
        encoding="utf-8",
    )
    for isolate in ("none", "all"):
        result = fmionnx.load(path).run(stop_time=2.0, isolate=isolate)
        assert result.status.value == "fault", isolate
        assert result.error is not None
        assert result.error.port == "y"
        assert "output has shape [3], not the shape the model declares for it ([1])" in str(
            result.error
        )


def test_a_port_with_a_dimension_of_0_is_e013(tmp_path: Path) -> None:
    # found by fuzzing models (issue 38): a declared shape [0] compiled, then the run divided
    # by it while naming its columns (ZeroDivisionError, a traceback)
    path = _onnx_model(tmp_path / "empty.onnx", [0], [0])
    result = api.check_model(path)
    (error,) = [d for d in result.diagnostics if d.code == codes.UNSUPPORTED_MODEL.code]
    assert "output `y` has a dimension of 0 [0]" in error.message
    assert error.hint == "a port carries at least one number"


def test_a_height_field_is_counted_at_what_mujoco_takes_for_it(tmp_path: Path) -> None:
    # found by fuzzing scenes (issue 38): 57 million height-field cells were counted at the 4
    # bytes a cell keeps in the model (0.23 GB, within the limit), and MuJoCo took 2.9 GB for
    # them and a texture, for 23 s, beyond the fuzzer's address-space cap
    path = tmp_path / "scene.xml"
    path.write_text(
        '<mujoco><asset><hfield name="h" nrow="7167512" ncol="8" size="1 1 0.1 0.1"/></asset>'
        '<worldbody><geom type="hfield" hfield="h"/></worldbody></mujoco>',
        "utf-8",
    )
    result = api.check_model(path)
    (error,) = [d for d in result.diagnostics if d.code == "E008"]
    assert "`<hfield>` of 57340096 cells" in error.message
