"""Fuzzing SSP XML: mutated SSD, SSV and SSM files end in diagnostics or a compile, never a
traceback or a hang (issue #17, point 6).

The seed is the OMSimulator-style system of ``tests/ssp`` (nested systems, a prefixed and a
mapped parameter set, a linear transformation, units, an OMSimulator annotation), loose: the
``.ssd`` beside ``resources/`` with the real test FMUs, read by the same front end that reads
``.ssp`` archives once unpacked (archives are fuzzed in ``test_fuzz_archives.py``). Each
example mutates one of its four XML files.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import build_fixture_fmu
from tests.fuzz.harness import fuzz_settings, validate_in_process
from tests.fuzz.mutations import XML_TOKENS, mutated_bytes, mutated_xml
from tests.ssp.conftest import CTRL_SSM, CTRL_SSV, FOREIGN_SSD, GAIN1_SSV

SSD = "system.ssd"
#: The XML files of the seed system, by their place beside the ``.ssd``.
XML_FILES: dict[str, bytes] = {
    SSD: FOREIGN_SSD.encode(),
    "resources/gain1.ssv": GAIN1_SSV.encode(),
    "resources/ctrl.ssv": CTRL_SSV.encode(),
    "resources/ctrl.ssm": CTRL_SSM.encode(),
}
FMUS = {
    "resources/0001_integ.fmu": "Integrator",
    "resources/0002_gain1.fmu": "Gain",
    "resources/0003_gain2.fmu": "Gain",
}


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The loose system: its XML files (rewritten by every example) and the FMUs."""
    work = tmp_path_factory.mktemp("fuzz-ssd")
    (work / "resources").mkdir()
    for name, fixture in FMUS.items():
        # Copies, not links: a resource that links outside the system's folder is E017.
        shutil.copyfile(build_fixture_fmu(fixture), work / name)
    return work


def write(folder: Path, name: str, content: bytes) -> Path:
    """The seed's XML files with ``name`` replaced by ``content``; returns the ``.ssd``."""
    for other, seed in XML_FILES.items():
        (folder / other).write_bytes(content if other == name else seed)
    return folder / SSD


def test_the_seed_compiles_cleanly(folder: Path) -> None:
    """Mutations start from a system that compiles: otherwise they would all stop at the same
    first error and test nothing beyond it."""
    path = write(folder, SSD, XML_FILES[SSD])
    result = validate_in_process(path, XML_FILES[SSD])
    assert result.ok, [d.message for d in result.diagnostics]


@given(st.sampled_from(sorted(XML_FILES)), st.data())
@fuzz_settings(150)
def test_byte_mutated_ssp_xml_ends_in_diagnostics(
    folder: Path, name: str, data: st.DataObject
) -> None:
    """Stray bytes, truncation, entities and DTDs (XXE, billion laughs), XInclude, broken
    encodings in any of the system's XML files."""
    mutated = data.draw(mutated_bytes(XML_FILES[name], XML_TOKENS), label=name)
    validate_in_process(write(folder, name, mutated), mutated)


@given(st.sampled_from(sorted(XML_FILES)), st.data())
@fuzz_settings(150)
def test_structure_mutated_ssp_xml_ends_in_diagnostics(
    folder: Path, name: str, data: st.DataObject
) -> None:
    """Well-formed XML that says the wrong thing: elements dropped, duplicated, moved or
    renamed, attributes set to other references, non-finite or huge numbers, paths outside
    the system's folder."""
    mutated = data.draw(mutated_xml(XML_FILES[name]), label=name)
    validate_in_process(write(folder, name, mutated), mutated)


@given(st.data())
@fuzz_settings(80)
def test_attribute_mutations_that_pass_the_schema_reach_the_compiler(
    folder: Path, data: st.DataObject
) -> None:
    """One attribute of the SSD set to another value: most such files still validate against
    the SSP XSD (names, references and numbers are strings and doubles to it), so this reaches
    the flattening, parameter and connection checks behind the schema."""
    mutated = data.draw(mutated_xml(XML_FILES[SSD], max_ops=1, ops=("attr",)), label=SSD)
    validate_in_process(write(folder, SSD, mutated), mutated)
