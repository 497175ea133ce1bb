"""FMU interface reader: ports, grouping, units, dependencies, facts, caching, errors."""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Causality, ComponentInterface, DType, Experiment
from fmionnx.kinds.cache import clear_cache
from fmionnx.kinds.fmu import kind as kind_module
from fmionnx.kinds.fmu.kind import FMU_KIND
from tests.components.fmi_xml import fmi2, fmi3, fmu_folder, fmu_zip, scalar

BuildFmu = Callable[[str], Path]
FIXTURES = Path(__file__).resolve().parent.parent / "fixtures" / "fmus"


@pytest.fixture(autouse=True)
def _fresh_cache() -> None:
    clear_cache()


def test_gain_ports_group_fmi2_arrays_in_element_order(fixture_fmu: BuildFmu) -> None:
    interface = FMU_KIND.read_interface(fixture_fmu("Gain"), None)
    assert [p.name for p in interface.ports] == ["u", "k", "y", "v", "w"]
    v, w = interface.port("v"), interface.port("w")
    assert v is not None
    assert w is not None
    assert (v.shape, v.vrs, v.causality, v.start) == ((3,), (3, 4, 5), Causality.INPUT, (0.0,) * 3)
    assert (w.shape, w.vrs, w.causality) == ((3,), (6, 7, 8), Causality.OUTPUT)


def test_gain_units_come_from_variable_or_declared_type(fixture_fmu: BuildFmu) -> None:
    interface = FMU_KIND.read_interface(fixture_fmu("Gain"), None)
    units = {p.name: p.unit for p in interface.ports}
    assert units == {"u": "m", "k": None, "y": "m", "v": "m", "w": "m"}


def test_gain_outputs_depend_on_declared_inputs(fixture_fmu: BuildFmu) -> None:
    interface = FMU_KIND.read_interface(fixture_fmu("Gain"), None)
    depends = {p.name: p.depends_on for p in interface.ports}
    assert depends == {"u": None, "k": None, "y": ("u",), "v": None, "w": ("v",)}


def test_gain_parameter_start_and_origin_line(fixture_fmu: BuildFmu) -> None:
    path = fixture_fmu("Gain")
    k = FMU_KIND.read_interface(path, None).port("k")
    assert k is not None
    assert (k.causality, k.dtype, k.start, k.variability) == (
        Causality.PARAMETER,
        DType.FLOAT64,
        (2.0,),
        "fixed",
    )
    line = next(
        n
        for n, text in enumerate(
            (FIXTURES / "Gain" / "modelDescription.xml").read_text().splitlines(), 1
        )
        if 'name="k"' in text
    )
    assert k.origin == Span(Path(path.name) / "modelDescription.xml", line)


def test_gain_facts_and_default_experiment(fixture_fmu: BuildFmu) -> None:
    path = fixture_fmu("Gain")
    interface = FMU_KIND.read_interface(path, None)
    facts = dict(interface.facts)
    assert facts["fmiVersion"] == "2.0"
    assert facts["modelName"] == "Gain"
    assert facts["instantiationToken"] == "{6d3c5a8e-0b5e-4f7e-9a51-67a1c0f1e201}"
    assert facts["interfaceTypes"] == "cs,me"
    assert facts["modelIdentifierCS"] == facts["modelIdentifierME"] == "Gain"
    assert facts["platforms"] == "linux64"
    assert facts["hasSources"] == "true"
    assert facts["canHandleVariableCommunicationStepSize"] == "true"
    assert facts["generationTool"] == "fmionnx test fixtures"
    assert interface.default_experiment == Experiment(start=0.0, stop=1.0, step=0.01)
    assert interface.content_hash == hashlib.sha256(path.read_bytes()).hexdigest()
    assert interface.kind == "fmu"
    assert interface.path == path


def test_integrator_state_output_has_no_direct_feedthrough(fixture_fmu: BuildFmu) -> None:
    interface = FMU_KIND.read_interface(fixture_fmu("Integrator"), None)
    assert [p.name for p in interface.ports] == ["u", "x0", "x", "xStop"]
    x = interface.port("x")
    assert x is not None
    assert x.depends_on == ()
    assert interface.fact("numberOfContinuousStates") == "1"


def test_faulty_is_cs_only_with_integer_mode(fixture_fmu: BuildFmu) -> None:
    interface = FMU_KIND.read_interface(fixture_fmu("Faulty"), None)
    mode = interface.port("mode")
    assert mode is not None
    assert (mode.dtype, mode.start, mode.vrs) == (DType.INT32, (0,), (3,))
    assert interface.fact("interfaceTypes") == "cs"
    assert interface.fact("modelIdentifierME") is None


def test_vector3_fmi3_arrays_keep_one_value_reference(fixture_fmu: BuildFmu) -> None:
    interface = FMU_KIND.read_interface(fixture_fmu("Vector3"), None)
    assert [p.name for p in interface.ports] == ["u", "k", "y", "count", "stopAt"]
    u, y, count = interface.port("u"), interface.port("y"), interface.port("count")
    assert u is not None
    assert y is not None
    assert count is not None
    assert (u.shape, u.vrs, u.unit, u.start) == ((3,), (1,), "N", (0.0, 0.0, 0.0))
    assert (y.shape, y.vrs, y.depends_on) == ((3,), (3,), ("u",))
    assert (count.dtype, count.shape, count.depends_on) == (DType.INT32, (), ())
    assert interface.fact("fmiVersion") == "3.0"
    assert interface.fact("platforms") == "x86_64-linux"


def test_unpacked_folder_reads_like_the_archive(fixture_fmu: BuildFmu) -> None:
    packed = FMU_KIND.read_interface(fixture_fmu("Gain"), None)
    folder = FMU_KIND.read_interface(FIXTURES / "Gain", None)
    assert [(p.name, p.shape, p.vrs) for p in folder.ports] == [
        (p.name, p.shape, p.vrs) for p in packed.ports
    ]
    assert folder.fact("platforms") is None
    assert folder.fact("hasSources") == "true"
    assert folder.ports[0].origin == Span(Path("Gain/modelDescription.xml"), 37)


def test_repeated_reads_are_served_from_the_cache(
    fixture_fmu: BuildFmu, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Counted, not timed: 200 reads "under half a second" failed on a loaded machine.
    path = fixture_fmu("Gain")
    first = FMU_KIND.read_interface(path, None)
    loads: list[Path] = []
    real = kind_module.load_fmu_interface

    def counted(read: Path) -> ComponentInterface:
        loads.append(read)
        return real(read)

    monkeypatch.setattr(kind_module, "load_fmu_interface", counted)
    for _ in range(200):
        again = FMU_KIND.read_interface(path, None)
    assert loads == []
    assert again.ports is first.ports


def test_cache_sees_a_changed_file(fixture_fmu: BuildFmu, tmp_path: Path) -> None:
    path = tmp_path / "M.fmu"
    shutil.copy(fixture_fmu("Gain"), path)
    assert FMU_KIND.read_interface(path, None).fact("modelName") == "Gain"
    shutil.copy(fixture_fmu("Integrator"), path)
    os.utime(path, ns=(1, 1))
    assert FMU_KIND.read_interface(path, None).fact("modelName") == "Integrator"


# --- FMI 2 grouping rules on hand-written model descriptions


def _read_fmi2(tmp_path: Path, variables: list[str], structure: str = "") -> list[tuple]:
    folder = fmu_folder(tmp_path, "T", fmi2(variables, structure))
    ports = FMU_KIND.read_interface(folder, None).ports
    return [(p.name, p.shape, p.vrs) for p in ports]


def test_fmi2_two_dimensional_scalars_group_row_major(tmp_path: Path) -> None:
    names = ["a[1,1]", "a[2,1]", "a[1,2]", "a[2,2]", "a[1,3]", "a[2,3]"]
    variables = [scalar(n, i, "input") for i, n in enumerate(names)]
    assert _read_fmi2(tmp_path, variables) == [("a", (2, 3), (0, 2, 4, 1, 3, 5))]


def test_fmi2_scalars_with_a_gap_stay_scalar(tmp_path: Path) -> None:
    variables = [scalar("x[1]", 0, "input"), scalar("x[3]", 1, "input")]
    assert _read_fmi2(tmp_path, variables) == [("x[1]", (), (0,)), ("x[3]", (), (1,))]


def test_fmi2_scalars_of_mixed_causality_stay_scalar(tmp_path: Path) -> None:
    variables = [scalar("x[1]", 0, "input"), scalar("x[2]", 1, "parameter")]
    assert _read_fmi2(tmp_path, variables) == [("x[1]", (), (0,)), ("x[2]", (), (1,))]


def test_fmi2_scalars_of_mixed_type_stay_scalar(tmp_path: Path) -> None:
    variables = [scalar("x[1]", 0, "input"), scalar("x[2]", 1, "input", "Integer")]
    assert [n for n, _, _ in _read_fmi2(tmp_path, variables)] == ["x[1]", "x[2]"]


def test_fmi2_scalars_are_not_grouped_over_a_plain_variable(tmp_path: Path) -> None:
    variables = [scalar("x", 0, "input"), scalar("x[1]", 1, "input")]
    assert [n for n, _, _ in _read_fmi2(tmp_path, variables)] == ["x", "x[1]"]


def test_fmi2_locals_and_independent_are_not_ports(tmp_path: Path) -> None:
    variables = [
        '<ScalarVariable name="time" valueReference="0" causality="independent"><Real/>'
        "</ScalarVariable>",
        scalar("l", 1, "local", type_attrs='start="1"', variability="fixed").replace(
            'causality="local" variability="fixed"><Real ',
            'causality="local" variability="constant"><Real ',
        ),
        scalar("p", 2, "parameter"),
    ]
    assert [n for n, _, _ in _read_fmi2(tmp_path, variables)] == ["p"]


def test_fmi2_dtypes(tmp_path: Path) -> None:
    variables = [
        scalar("r", 0, "input"),
        scalar("i", 1, "input", "Integer"),
        scalar("b", 2, "input", "Boolean"),
        scalar("s", 3, "input", "String"),
        scalar("e", 4, "input", "Enumeration", 'declaredType="E"'),
    ]
    extra = (
        '<TypeDefinitions><SimpleType name="E"><Enumeration>'
        '<Item name="a" value="0"/><Item name="b" value="1"/></Enumeration></SimpleType>'
        "</TypeDefinitions>"
    )
    folder = fmu_folder(tmp_path, "T", fmi2(variables, extra=extra))
    ports = FMU_KIND.read_interface(folder, None).ports
    assert [(p.name, p.dtype, p.start) for p in ports] == [
        ("r", DType.FLOAT64, (0.0,)),
        ("i", DType.INT32, (0,)),
        ("b", DType.BOOL, (False,)),
        ("s", DType.STRING, ("",)),
        ("e", DType.INT32, (0,)),
    ]


def test_fmi2_output_without_dependencies_attribute_is_unknown(tmp_path: Path) -> None:
    variables = [scalar("u", 0, "input"), scalar("y", 1, "output"), scalar("z", 2, "output")]
    structure = '<Outputs><Unknown index="2"/><Unknown index="3" dependencies="1"/></Outputs>'
    folder = fmu_folder(tmp_path, "T", fmi2(variables, structure))
    ports = FMU_KIND.read_interface(folder, None)
    assert [(p.name, p.depends_on) for p in ports.ports] == [
        ("u", None),
        ("y", None),
        ("z", ("u",)),
    ]


# --- FMI 3 types and dimensions


def test_fmi3_dtypes_and_clock_skipped(tmp_path: Path) -> None:
    variables = [
        '<Float32 name="f" valueReference="1" causality="input" start="1.5"/>',
        '<Int8 name="i8" valueReference="2" causality="input" start="-3"/>',
        '<UInt64 name="u64" valueReference="3" causality="input" start="7"/>',
        '<Boolean name="b" valueReference="4" causality="input" start="true"/>',
        '<String name="s" valueReference="5" causality="input"><Start value="hi"/></String>',
        '<Binary name="bin" valueReference="6" causality="input"><Start value="0a0b"/></Binary>',
        '<Enumeration name="e" valueReference="7" causality="input" declaredType="E" start="1"/>',
        '<Clock name="c" valueReference="8" causality="input" intervalVariability="triggered"/>',
    ]
    extra = '<TypeDefinitions><EnumerationType name="E"><Item name="a" value="1"/></EnumerationType></TypeDefinitions>'
    folder = fmu_folder(tmp_path, "T", fmi3(variables, extra=extra))
    ports = FMU_KIND.read_interface(folder, None).ports
    assert [(p.name, p.dtype, p.start) for p in ports] == [
        ("f", DType.FLOAT32, (1.5,)),
        ("i8", DType.INT8, (-3,)),
        ("u64", DType.UINT64, (7,)),
        ("b", DType.BOOL, (True,)),
        ("s", DType.STRING, ("hi",)),
        ("bin", DType.BINARY, ("0a0b",)),
        ("e", DType.INT64, (1,)),
    ]


def test_fmi3_dimension_from_structural_parameter(tmp_path: Path) -> None:
    variables = [
        '<UInt64 name="n" valueReference="1" causality="structuralParameter" '
        'variability="fixed" start="4"/>',
        '<Float64 name="x" valueReference="2" causality="input" start="0 1 2 3">'
        '<Dimension valueReference="1"/></Float64>',
        '<Float64 name="m" valueReference="3" causality="parameter" variability="fixed" '
        'start="1"><Dimension start="2"/><Dimension start="3"/></Float64>',
    ]
    folder = fmu_folder(tmp_path, "T", fmi3(variables))
    interface = FMU_KIND.read_interface(folder, None)
    assert [(p.name, p.causality, p.shape, p.start) for p in interface.ports] == [
        ("n", Causality.STRUCTURAL_PARAMETER, (), (4,)),
        ("x", Causality.INPUT, (4,), (0.0, 1.0, 2.0, 3.0)),
        ("m", Causality.PARAMETER, (2, 3), (1.0,) * 6),
    ]


# --- error paths


def _code(path: Path) -> str:
    with pytest.raises(ModelError) as info:
        FMU_KIND.read_interface(path, None)
    return info.value.code.code


def test_missing_file_is_e010(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="does not exist") as info:
        FMU_KIND.read_interface(tmp_path / "nope.fmu", None)
    assert info.value.code is codes.FILE_NOT_FOUND


def test_folder_without_model_description_is_e011(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match=r"without modelDescription\.xml") as info:
        FMU_KIND.read_interface(tmp_path, None)
    assert info.value.code is codes.NOT_A_FILE


def test_non_zip_fmu_is_e012(tmp_path: Path) -> None:
    path = tmp_path / "text.fmu"
    path.write_text("not a zip")
    with pytest.raises(ModelError, match="not a zip archive") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.BAD_MODEL


def test_zip_without_model_description_is_e012(tmp_path: Path) -> None:
    path = fmu_zip(tmp_path / "empty.fmu", {"readme.txt": b"hello"})
    with pytest.raises(ModelError, match=r"has no modelDescription\.xml") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.BAD_MODEL


def test_fmi1_model_description_is_unsupported_e013(tmp_path: Path) -> None:
    xml = (
        '<?xml version="1.0"?><fmiModelDescription fmiVersion="1.0" modelName="Old" '
        'modelIdentifier="Old" guid="{x}"><ModelVariables/></fmiModelDescription>'
    )
    path = fmu_zip(tmp_path / "old.fmu", {"modelDescription.xml": xml.encode()})
    with pytest.raises(ModelError, match=r"FMI 1\.0 FMU") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSUPPORTED_MODEL
    assert info.value.hint is not None


@pytest.mark.parametrize(
    ("member", "message"),
    [("../evil.txt", "outside the archive"), ("/etc/evil", "absolute path")],
)
def test_hostile_member_names_are_e017(tmp_path: Path, member: str, message: str) -> None:
    xml = fmi2([scalar("u", 0, "input")]).encode()
    path = fmu_zip(tmp_path / "evil.fmu", {"modelDescription.xml": xml, member: b"x"})
    with pytest.raises(ModelError, match=message) as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_symlink_member_is_e017(tmp_path: Path) -> None:
    xml = fmi2([scalar("u", 0, "input")]).encode()
    members = {"modelDescription.xml": xml, "resources/link": b"/etc/passwd"}
    path = fmu_zip(tmp_path / "link.fmu", members, links=("resources/link",))
    with pytest.raises(ModelError, match="symbolic link") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_zip_bomb_ratio_is_e017(tmp_path: Path) -> None:
    xml = fmi2([scalar("u", 0, "input")]).encode()
    members = {"modelDescription.xml": xml, "resources/zeros.bin": bytes(8 * 1024**2)}
    path = fmu_zip(tmp_path / "bomb.fmu", members)
    with pytest.raises(ModelError, match="zip bomb") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_dtd_with_external_entity_is_refused_e017(tmp_path: Path) -> None:
    xml = fmi2([scalar("u", 0, "input")]).replace(
        "<fmiModelDescription",
        '<!DOCTYPE fmiModelDescription [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
        "<fmiModelDescription",
        1,
    )
    folder = fmu_folder(tmp_path, "T", xml)
    with pytest.raises(ModelError, match="declares a DTD") as info:
        FMU_KIND.read_interface(folder, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_malformed_xml_is_e012_with_line(tmp_path: Path) -> None:
    folder = fmu_folder(tmp_path, "T", '<?xml version="1.0"?>\n<fmiModelDescription\n<oops')
    with pytest.raises(ModelError, match=r"not well-formed XML \(line \d+\)") as info:
        FMU_KIND.read_interface(folder, None)
    assert info.value.code is codes.BAD_MODEL


def test_schema_violation_is_e012(tmp_path: Path) -> None:
    xml = fmi2(
        [
            '<ScalarVariable name="u" valueReference="0" causality="sideways"><Real/>'
            "</ScalarVariable>"
        ]
    )
    folder = fmu_folder(tmp_path, "T", xml)
    with pytest.raises(ModelError, match="does not conform to the FMI schema") as info:
        FMU_KIND.read_interface(folder, None)
    assert info.value.code is codes.BAD_MODEL


def test_other_root_element_is_e012(tmp_path: Path) -> None:
    folder = fmu_folder(tmp_path, "T", "<html/>")
    assert _code(folder) == "E012"


def test_corrupt_member_is_e012(tmp_path: Path) -> None:
    xml = fmi2([scalar("u", 0, "input")]).encode()
    path = tmp_path / "crc.fmu"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as archive:
        archive.writestr("modelDescription.xml", xml)
    data = bytearray(path.read_bytes())
    at = data.index(b'name="u"')
    data[at + 6] ^= 0x01  # same length, different bytes: the CRC no longer matches
    path.write_bytes(bytes(data))
    with pytest.raises(ModelError, match="is corrupt") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.BAD_MODEL


@pytest.mark.parametrize(
    ("structure", "expected"),
    [
        (
            '<Outputs><Unknown index="9"/></Outputs>',
            '<Outputs> <Unknown index="9"> names no variable: an index is a whole number from 1 '
            "to the number of ScalarVariables (2)",
        ),
        (
            '<Outputs><Unknown index="2" dependencies="1 3"/></Outputs>',
            '<Outputs> <Unknown dependencies="1 3"> names no variable',
        ),
    ],
)
def test_an_fmi2_structure_index_of_no_variable_is_e012_with_its_line(
    tmp_path: Path, structure: str, expected: str
) -> None:
    """A bug hunt: ``cannot be read: list index out of range`` (fmpy's IndexError)."""
    variables = [scalar("u", 0, "input"), scalar("y", 1, "output")]
    folder = fmu_folder(tmp_path, "T", fmi2(variables, structure))
    with pytest.raises(ModelError) as info:
        FMU_KIND.read_interface(folder, None)
    assert info.value.code is codes.BAD_MODEL
    assert re.search(r"cannot be read: line \d+: ", str(info.value)), str(info.value)
    assert expected in str(info.value)


@pytest.mark.parametrize(
    ("structure", "expected"),
    [
        ('<Output valueReference="9"/>', "no variable has the value reference 9"),
        (
            '<Output valueReference="2" dependencies="1 7"/>',
            "no variable has the value reference 7",
        ),
    ],
)
def test_an_fmi3_structure_reference_to_no_variable_is_e012_with_its_line(
    tmp_path: Path, structure: str, expected: str
) -> None:
    variables = [
        '<Float64 name="u" valueReference="1" causality="input" start="0"/>',
        '<Float64 name="y" valueReference="2" causality="output"/>',
    ]
    folder = fmu_folder(tmp_path, "T", fmi3(variables, structure))
    with pytest.raises(ModelError) as info:
        FMU_KIND.read_interface(folder, None)
    assert info.value.code is codes.BAD_MODEL
    assert re.search(r"cannot be read: line \d+: <Output ", str(info.value)), str(info.value)
    assert expected in str(info.value)


# --- declared min and max


def test_fmi2_bounds_come_from_the_variable_or_its_declared_type(tmp_path: Path) -> None:
    variables = [
        scalar("a", 0, "parameter", "Real", 'min="-1.5" max="2"'),
        scalar("n", 1, "parameter", "Integer", 'max="13"'),
        scalar("t", 2, "parameter", "Real", 'declaredType="Pos"'),
        scalar("o", 3, "parameter", "Real", 'declaredType="Pos" min="-3"'),  # its own wins
        scalar("free", 4, "input"),
        scalar("v[1]", 5, "input", "Real", 'min="0"'),
        scalar("v[2]", 6, "input", "Real", 'min="0"'),
        scalar("w[1]", 7, "input", "Real", 'min="0"'),
        scalar("w[2]", 8, "input", "Real", 'min="1"'),
    ]
    types = '<TypeDefinitions><SimpleType name="Pos"><Real min="0"/></SimpleType></TypeDefinitions>'
    folder = fmu_folder(tmp_path, "T", fmi2(variables, extra=types))
    ports = FMU_KIND.read_interface(folder, None).ports
    assert [(p.name, p.bounds) for p in ports] == [
        ("a", (-1.5, 2.0)),
        ("n", (None, 13)),
        ("t", (0.0, None)),
        ("o", (-3.0, None)),
        ("free", (None, None)),
        ("v", (0.0, None)),  # every element declares the same
        ("w", (None, None)),  # they differ: none for the port
    ]


def test_fmi3_bounds_are_read(tmp_path: Path) -> None:
    variables = [
        '<Float64 name="x" valueReference="1" causality="parameter" variability="fixed" '
        'start="1" min="0" max="10"/>',
        '<Int8 name="m" valueReference="2" causality="input" start="1" max="4"/>',
        # fmpy reads no bounds of unsigned types (its check is `startswith("Int")`): read
        # from the XML (they were none, and a value above 4 was set without a word)
        '<UInt8 name="u" valueReference="3" causality="input" start="1" max="4"/>',
    ]
    folder = fmu_folder(tmp_path, "T", fmi3(variables))
    ports = FMU_KIND.read_interface(folder, None).ports
    assert [(p.name, p.bounds) for p in ports] == [
        ("x", (0.0, 10.0)),
        ("m", (None, 4)),
        ("u", (None, 4)),
    ]
