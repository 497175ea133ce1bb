"""SSP resources stay inside their archive or the .ssd's folder; SSP XML size is bounded.

Archives and loose SSDs are written here; the components are the test FMUs built from C.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.frontends import load_system
from tests.ssp.conftest import write_ssp
from tests.ssp.test_import import gain, ssd

SSV = (
    '<?xml version="1.0"?>\n<ssv:ParameterSet '
    'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues" '
    'version="1.0" name="a">\n<ssv:Parameters>\n'
    '<ssv:Parameter name="k"><ssv:Real value="2"/></ssv:Parameter>\n'
    "</ssv:Parameters></ssv:ParameterSet>\n"
)


def _codes(path: Path) -> list[tuple[str, str]]:
    bag = DiagnosticBag()
    load_system(path, bag)
    return [(d.code, d.message) for d in bag if d.severity.label == "error"]


@pytest.fixture
def layout(tmp_path: Path, fixture_fmu) -> Path:  # type: ignore[no-untyped-def]
    """``system/`` (where the .ssd goes) beside ``outside/`` holding a real FMU and an SSV."""
    (tmp_path / "system" / "resources").mkdir(parents=True)
    outside = tmp_path / "outside"
    outside.mkdir()
    shutil.copy(fixture_fmu("Gain"), outside / "Gain.fmu")
    (outside / "a.ssv").write_text(SSV, encoding="utf-8")
    return tmp_path / "system"


def _loose(folder: Path, body: str) -> Path:
    path = folder / "system.ssd"
    path.write_text(ssd(body), encoding="utf-8")
    return path


def test_a_loose_ssd_component_outside_its_folder_is_e017(layout: Path) -> None:
    path = _loose(layout, f"<ssd:Elements>{gain('a', source='../outside/Gain.fmu')}</ssd:Elements>")
    (found,) = _codes(path)
    assert found == ("E017", "`../outside/Gain.fmu` points outside the folder of the .ssd")


def test_a_loose_ssd_parameter_file_outside_its_folder_is_e017(layout: Path, fixture_fmu) -> None:  # type: ignore[no-untyped-def]
    shutil.copy(fixture_fmu("Gain"), layout / "resources" / "Gain.fmu")
    binding = (
        '<ssd:ParameterBindings><ssd:ParameterBinding source="../outside/a.ssv"/>'
        "</ssd:ParameterBindings>"
    )
    path = _loose(layout, f"<ssd:Elements>{gain('a', extra=binding)}</ssd:Elements>")
    assert ("E017", "`../outside/a.ssv` points outside the folder of the .ssd") in _codes(path)


def test_a_link_out_of_the_ssd_folder_is_e017(layout: Path) -> None:
    (layout / "resources" / "Gain.fmu").symlink_to(layout.parent / "outside" / "Gain.fmu")
    path = _loose(layout, f"<ssd:Elements>{gain('a')}</ssd:Elements>")
    (found,) = _codes(path)
    assert found[0] == "E017"


def test_an_ssp_component_outside_the_archive_is_e017(tmp_path: Path) -> None:
    body = f"<ssd:Elements>{gain('a', source='../../outside/Gain.fmu')}</ssd:Elements>"
    archive = write_ssp(tmp_path / "bad.ssp", {"SystemStructure.ssd": ssd(body)})
    (found,) = _codes(archive)
    assert found == ("E017", "`../../outside/Gain.fmu` points outside the SSP archive")


def test_an_ssd_larger_than_the_limit_is_e008_before_parsing(
    layout: Path,
    monkeypatch: pytest.MonkeyPatch,
    fixture_fmu,  # type: ignore[no-untyped-def]
) -> None:
    shutil.copy(fixture_fmu("Gain"), layout / "resources" / "Gain.fmu")
    padding = "<!--" + "x" * 5000 + "-->"
    path = _loose(layout, f"<ssd:Elements>{gain('a')}</ssd:Elements>{padding}")
    assert _codes(path) == []
    monkeypatch.setenv("FMIONNX_MAX_SSP_XML_BYTES", "4096")
    (found,) = _codes(path)
    assert found[0] == "E008"
    assert "larger than 4096" in found[1]
