"""FMUs: the shared library comes from inside the FMU; declared arrays are bounded.

Model descriptions are written here and zipped with ``zipfile``; the runs use the test FMUs
compiled from C (tests/fixtures/fmus).
"""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import pytest

import fmionnx
from fmionnx.core import codes
from fmionnx.core.errors import DiagnosticError, ModelError
from fmionnx.kinds.fmu.build import build_fmu
from fmionnx.kinds.fmu.kind import FMU_KIND
from fmionnx.pipeline.errors import RefusedError
from tests.components.fmi_xml import fmi2, fmi3, fmu_zip, scalar
from tests.conftest import FIXTURES, build_fixture_fmu
from tests.security.conftest import run_capped

BILLION = 10**9


def _with_identifier(identifier: str) -> bytes:
    xml = fmi2([scalar("u", 0, "input")])
    return xml.replace('modelIdentifier="T"', f'modelIdentifier="{identifier}"').encode()


@pytest.mark.parametrize(
    "identifier",
    ["../../../../elsewhere/evil", "/nonexistent/evil", "sub/evil", "evil\\..\\..\\x", ".."],
    ids=["dotdot", "absolute", "separator", "backslash", "parent"],
)
def test_a_model_identifier_that_is_a_path_is_e017(tmp_path: Path, identifier: str) -> None:
    path = fmu_zip(tmp_path / "evil.fmu", {"modelDescription.xml": _with_identifier(identifier)})
    with pytest.raises(ModelError, match="not a plain name") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert "modelDescription.xml" in str(info.value)


def _unpacked(fmu: Path, folder: Path) -> Path:
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    return folder


def _swap_for_link(folder: Path, outside: Path) -> Path:
    """Replace the FMU's library by a link to a copy of it outside the folder."""
    library = next((folder / "binaries").glob("*/Integrator.so"))
    outside.mkdir()
    copy = outside / "Integrator.so"
    shutil.copy(library, copy)
    library.unlink()
    library.symlink_to(copy)
    return library


def test_a_library_linked_from_outside_the_fmu_is_refused_when_compiling(tmp_path: Path) -> None:
    folder = _unpacked(build_fixture_fmu("Integrator"), tmp_path / "Integrator.fmu")
    _swap_for_link(folder, tmp_path / "outside")
    with pytest.raises(DiagnosticError) as info:
        fmionnx.load(folder, step=0.01)
    (problem,) = [d for d in info.value.diagnostics if d.code == "E017"]
    assert "outside the FMU" in problem.message


def test_a_library_swapped_after_compiling_is_refused_before_loading(tmp_path: Path) -> None:
    folder = _unpacked(build_fixture_fmu("Integrator"), tmp_path / "Integrator.fmu")
    system = fmionnx.load(folder, step=0.01)
    _swap_for_link(folder, tmp_path / "outside")
    with pytest.raises(RefusedError, match="outside the FMU") as info:
        system.run(isolate="none", stop_time=0.1)
    cause = info.value.__cause__
    assert isinstance(cause, ModelError)
    assert cause.code is codes.UNSAFE_ARCHIVE


def test_an_unchanged_unpacked_fmu_still_runs(tmp_path: Path) -> None:
    folder = _unpacked(build_fixture_fmu("Integrator"), tmp_path / "Integrator.fmu")
    result = fmionnx.load(folder, step=0.01).run(isolate="none", stop_time=0.1, params={"u": 1.0})
    assert result["x"][-1] == pytest.approx(0.1)


def _fmi3_zip(path: Path, variables: list[str]) -> Path:
    return fmu_zip(path, {"modelDescription.xml": fmi3(variables).encode()})


def test_a_billion_element_array_is_e008_at_its_line(tmp_path: Path) -> None:
    variable = (
        '<Float64 name="x" valueReference="1" causality="output">'
        f'<Dimension start="{BILLION}"/></Float64>'
    )
    path = _fmi3_zip(tmp_path / "huge.fmu", [variable])
    assert path.stat().st_size < 2048
    with pytest.raises(ModelError, match=f"`x` declares {BILLION} elements") as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.RESOURCE_LIMIT
    assert "huge.fmu/modelDescription.xml:7" in str(info.value)
    assert "FMIONNX_MAX_ARRAY_ELEMENTS" in (info.value.hint or "")


READ_IN_CHILD = """
from pathlib import Path
from fmionnx.core.errors import ModelError
from fmionnx.kinds.fmu.kind import FMU_KIND
try:
    ports = FMU_KIND.read_interface(Path({path!r}), None).ports
    print("read", [p.name for p in ports])
except ModelError as exc:
    print(exc.code.code)
"""


def test_array_limits_hold_before_anything_is_allocated(tmp_path: Path) -> None:
    """A start value for a structural 10^9 dimension: without the check, 8 GB of start values."""
    variables = [
        '<UInt64 name="n" valueReference="1" causality="structuralParameter" '
        f'variability="fixed" start="{BILLION}"/>',
        '<Float64 name="x" valueReference="2" causality="input" start="0">'
        '<Dimension valueReference="1"/></Float64>',
    ]
    path = _fmi3_zip(tmp_path / "structural.fmu", variables)
    child = run_capped(READ_IN_CHILD.format(path=str(path)))
    assert child.stdout.strip() == "E008", child.stderr[-2000:]


def test_an_fmi2_index_of_a_billion_is_one_scalar_not_a_box(tmp_path: Path) -> None:
    variables = [scalar(f"v[{BILLION}]", 1, "output")]
    xml = fmi2(variables).encode()
    path = fmu_zip(tmp_path / "index.fmu", {"modelDescription.xml": xml})
    child = run_capped(READ_IN_CHILD.format(path=str(path)))
    assert child.stdout.strip() == f"read ['v[{BILLION}]']", child.stderr[-2000:]


def test_a_raised_limit_admits_the_array(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    variable = (
        '<Float64 name="x" valueReference="1" causality="output">'
        '<Dimension start="1000"/></Float64>'
    )
    path = _fmi3_zip(tmp_path / "small.fmu", [variable])
    monkeypatch.setenv("FMIONNX_MAX_ARRAY_ELEMENTS", "999")
    with pytest.raises(ModelError) as info:
        FMU_KIND.read_interface(path, None)
    assert info.value.code is codes.RESOURCE_LIMIT
    monkeypatch.setenv("FMIONNX_MAX_ARRAY_ELEMENTS", "1000")
    other = _fmi3_zip(tmp_path / "other.fmu", [variable])  # a new file: no cached interface
    assert FMU_KIND.read_interface(other, None).port("x").shape == (1000,)  # type: ignore[union-attr]


def test_a_negative_dimension_is_e012(tmp_path: Path) -> None:
    variables = [
        '<Int64 name="n" valueReference="1" causality="structuralParameter" '
        'variability="fixed" start="-3"/>',
        '<Float64 name="x" valueReference="2" causality="output">'
        '<Dimension valueReference="1"/></Float64>',
    ]
    with pytest.raises(ModelError, match="negative dimension") as info:
        FMU_KIND.read_interface(_fmi3_zip(tmp_path / "negative.fmu", variables), None)
    assert info.value.code is codes.BAD_MODEL


def _source_fmu(tmp_path: Path, edit: tuple[str, str]) -> Path:
    """The Gain test FMU's sources with one edit of its model description."""
    folder = tmp_path / "GainSource"
    shutil.copytree(FIXTURES / "fmus" / "Gain", folder)
    description = folder / "modelDescription.xml"
    text = description.read_text(encoding="utf-8")
    assert edit[0] in text
    description.write_text(text.replace(edit[0], edit[1]), encoding="utf-8")
    return folder


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (('<File name="model.c"/>', '<File name="../../outside.c"/>'), "outside the FMU's sources"),
        (('modelIdentifier="Gain" can', 'modelIdentifier="../../Gain" can'), "not a plain name"),
        (('modelIdentifier="Gain" can', 'modelIdentifier="Gain&#10;X:BOOL=ON" can'), "control"),
    ],
    ids=["source-file", "identifier", "cmake-line"],
)
def test_a_source_fmu_naming_files_outside_is_refused_before_building(
    tmp_path: Path, edit: tuple[str, str], message: str
) -> None:
    (tmp_path / "outside.c").write_text("int outside = 1;\n", encoding="utf-8")
    source = _source_fmu(tmp_path / "work", edit)
    output = tmp_path / "built.fmu"
    with pytest.raises(ModelError, match=message) as info:
        build_fmu(source, output)
    assert info.value.code is codes.UNSAFE_ARCHIVE
    assert not output.exists()
