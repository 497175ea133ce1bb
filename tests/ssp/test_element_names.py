"""Names and references an SSD gets wrong: each is an error at its line, nothing is dropped."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.frontends import load_system
from tests.ssp.conftest import SSP_NAMESPACES, write_ssp
from tests.ssp.test_import import gain, load


def _numbered(lines: list[str]) -> str:
    return "\n".join(lines) + "\n"


def _document(elements: list[str], *, version: str = ' version="1.0"') -> str:
    """An SSD with one line per element of the root system (line numbers are predictable)."""
    return _numbered(
        [
            '<?xml version="1.0" encoding="UTF-8"?>',
            f'<ssd:SystemStructureDescription {SSP_NAMESPACES} name="sys"{version}>',
            '<ssd:System name="root"><ssd:Elements>',
            *elements,
            "</ssd:Elements></ssd:System>",
            '<ssd:DefaultExperiment startTime="0" stopTime="1"/>',
            "</ssd:SystemStructureDescription>",
        ]
    )


@pytest.fixture
def models(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    """A folder holding ``resources/Gain.fmu`` and ``resources/Count.fmu``."""
    (tmp_path / "resources").mkdir()
    for name, fixture in (("Gain", "Gain"), ("Count", "Count2")):
        (tmp_path / "resources" / f"{name}.fmu").write_bytes(fixture_fmu(fixture).read_bytes())
    return tmp_path


def _diagnostics(path: Path) -> list[tuple[str, int, str, list[int]]]:
    bag = DiagnosticBag()
    assert load_system(path, bag).spec is None
    return [
        (d.code, d.span.line if d.span else 0, d.message, [n.span.line for n in d.notes if n.span])
        for d in bag.sorted()
    ]


def test_two_components_of_one_name_are_e007_at_the_second(models: Path) -> None:
    path = models / "dup.ssd"
    path.write_text(_document([gain("a"), gain("a", "resources/Count.fmu")]), encoding="utf-8")
    ((code, line, message, notes),) = _diagnostics(path)
    assert (code, line, notes) == ("E007", 5, [4])
    assert message == "the root system `root` has two elements named `a`"


def test_a_system_and_a_component_of_one_name_are_e007(models: Path) -> None:
    path = models / "dup.ssd"
    nested = f'<ssd:System name="a"><ssd:Elements>{gain("g")}</ssd:Elements></ssd:System>'
    path.write_text(_document([gain("a"), nested]), encoding="utf-8")
    ((code, line, _, notes),) = _diagnostics(path)
    assert (code, line, notes) == ("E007", 5, [4])


def test_a_dotted_name_equal_to_a_flattened_nested_name_is_e007(models: Path) -> None:
    path = models / "dotted.ssd"
    nested = ['<ssd:System name="s"><ssd:Elements>', gain("g"), "</ssd:Elements></ssd:System>"]
    path.write_text(_document([gain("s.g"), *nested]), encoding="utf-8")
    ((code, line, message, notes),) = _diagnostics(path)
    assert (code, line, notes) == ("E007", 6, [4])
    assert "component `g` of system `s` is named `s.g`" in message
    assert "like component `s.g` of the root system `root`" in message


def test_distinct_names_that_differ_only_in_their_system_are_kept(models: Path) -> None:
    path = models / "fine.ssd"
    nested = f'<ssd:System name="s"><ssd:Elements>{gain("a")}</ssd:Elements></ssd:System>'
    path.write_text(_document([gain("a"), nested]), encoding="utf-8")
    spec, found = load(path)
    assert spec is not None, found
    assert list(spec.components) == ["a", "s.a"]


def test_an_ssd_without_a_version_says_the_attribute_is_missing(models: Path) -> None:
    path = models / "ver.ssd"
    path.write_text(_document([gain("a")], version=""), encoding="utf-8")
    ((code, line, message, _),) = _diagnostics(path)
    assert (code, line) == ("E070", 2)
    assert message == (
        "`ver.ssd`: the required `version` attribute of `ssd:SystemStructureDescription` is missing"
    )


def test_a_source_naming_a_folder_of_the_archive_says_it_is_a_folder(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    archive = write_ssp(
        tmp_path / "folder.ssp",
        {
            "SystemStructure.ssd": _document([gain("a", "resources")]),
            "resources/Gain.fmu": fixture_fmu("Gain"),
        },
    )
    ((code, line, message, _),) = _diagnostics(archive)
    assert (code, line) == ("E072", 4)
    assert message == "`resources` is a folder in the SSP, not a file"
