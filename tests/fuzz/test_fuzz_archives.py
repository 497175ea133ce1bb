"""Fuzzing archives: mutated FMUs and SSPs end in diagnostics (E012, E017 ...) or a compile,
never a traceback or a hang (issue #17, point 6).

Seeds are real archives: test FMUs built from ``tests/fixtures/fmus`` (FMI 2 and FMI 3) and
the OMSimulator-style SSP of ``tests/ssp``. Mutations work on the zip itself (central
directory, local headers, deflate streams, lying sizes and methods, truncation) or rebuild a
well-formed zip that says something hostile (traversal names, duplicate members, a member
missing, a mutated model description). An FMU is read three ways, as fmionnx reads one: as a
component of a system (``validate system.yaml``), alone (``validate model.fmu``: FMPy's
checks) and through the FMU kind's ``read_interface``, whose documented failure is ModelError.
Nothing is run: a mutated binary is not something to load into the test process.
"""

from __future__ import annotations

import functools
import hashlib
import shutil
from collections.abc import Sequence
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fmionnx import api
from fmionnx.core.errors import ModelError
from fmionnx.kinds.fmu.kind import FMU_KIND
from tests.conftest import build_fixture_fmu
from tests.fuzz.harness import (
    check_diagnostics,
    fuzz_settings,
    guarded,
    record,
    validate_in_process,
)
from tests.fuzz.mutations import (
    COMMON_TOKENS,
    XML_TOKENS,
    Mutant,
    ZipLayout,
    mutated_zip,
    rebuild,
)
from tests.ssp.conftest import CTRL_SSM, CTRL_SSV, FOREIGN_SSD, GAIN1_SSV

SYSTEM = """fmionnx: 1
name: fuzzed
run: {{stop: 1, step: 0.01}}
components:
  model: {{kind: fmu, path: {name}}}
"""


def tokens_for(member: str) -> Sequence[bytes]:
    """XML tokens for the archive's XML members, plain ones for binaries and sources."""
    return XML_TOKENS if member.endswith((".xml", ".ssd", ".ssv", ".ssm")) else COMMON_TOKENS


@functools.cache
def fmu_seed(name: str) -> ZipLayout:
    """A test FMU (``Gain``: FMI 2, ``Vector3``: FMI 3), built on first use (cached by source
    hash) and read once: strategies below draw from it lazily, so collecting the tests builds
    nothing."""
    return ZipLayout.of(build_fixture_fmu(name).read_bytes())


@functools.cache
def ssp_seed() -> ZipLayout:
    """The OMSimulator-style archive of ``tests/ssp`` with its real FMUs."""
    gain = build_fixture_fmu("Gain").read_bytes()
    return ZipLayout.of(
        rebuild(
            [
                ("SystemStructure.ssd", FOREIGN_SSD.encode()),
                ("resources/0001_integ.fmu", build_fixture_fmu("Integrator").read_bytes()),
                ("resources/0002_gain1.fmu", gain),
                ("resources/0003_gain2.fmu", gain),
                ("resources/gain1.ssv", GAIN1_SSV.encode()),
                ("resources/ctrl.ssv", CTRL_SSV.encode()),
                ("resources/ctrl.ssm", CTRL_SSM.encode()),
            ]
        )
    )


FMU_SEEDS = ("Gain", "Vector3")
#: Mutated FMUs of either seed; the seed is drawn first, so failures shrink towards ``Gain``.
MUTATED_FMUS = st.sampled_from(FMU_SEEDS).flatmap(lambda n: mutated_zip(fmu_seed(n), tokens_for))
MUTATED_SSPS = st.deferred(lambda: mutated_zip(ssp_seed(), tokens_for))


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Where mutated archives are written, each under a name of its own content: interfaces
    are cached by (path, mtime, size), so reusing one name could hand back another archive's
    interface."""
    return tmp_path_factory.mktemp("fuzz-archives")


def write(folder: Path, data: bytes, suffix: str) -> Path:
    """``data`` as ``<sha256>.<suffix>`` in ``folder``."""
    path = folder / f"{hashlib.sha256(data).hexdigest()[:20]}{suffix}"
    path.write_bytes(data)
    return path


def read_interface(path: Path, mutant: Mutant) -> None:
    """The FMU kind's reader: an interface, or ModelError (its documented failure)."""

    def read() -> str:
        try:
            FMU_KIND.read_interface(path, None)
        except ModelError as error:
            return error.code.code
        return "ok"

    outcome = guarded("FmuKind.read_interface", repr(mutant), read)
    record(f"read_interface: {outcome}")
    assert outcome in {"ok", "E008", "E010", "E011", "E012", "E013", "E017"}, outcome


def test_the_seeds_compile_cleanly(folder: Path) -> None:
    """Unmutated, every seed compiles, alone and in a system: the mutations below are what
    makes their examples fail, not the harness."""
    for layout in map(fmu_seed, FMU_SEEDS):
        path = write(folder, layout.data, ".fmu")
        system = folder / "system.yaml"
        system.write_text(SYSTEM.format(name=path.name), encoding="utf-8")
        assert validate_in_process(system, "the seed").ok
        assert api.check_model(path).ok
        FMU_KIND.read_interface(path, None)
    path = write(folder, ssp_seed().data, ".ssp")
    result = validate_in_process(path, "the seed")
    assert result.ok, [d.message for d in result.diagnostics]


def test_zip_mutations_change_the_archive() -> None:
    """Every zip-level mutation yields other bytes than its seed (a mutation that silently did
    nothing would make a property compile the seed again and again)."""
    layout = fmu_seed("Gain")

    @given(mutated_zip(layout, tokens_for))
    @fuzz_settings(40)
    def differs(mutant: Mutant) -> None:
        assert mutant.data != layout.data, mutant

    differs()


@given(mutant=MUTATED_FMUS)
@fuzz_settings(200)
def test_mutated_fmus_end_in_diagnostics(folder: Path, mutant: Mutant) -> None:
    """A corrupt or hostile FMU named by a system, validated alone, and read by its kind:
    diagnostics or ModelError, never a traceback."""
    path = write(folder, mutant.data, ".fmu")
    system = folder / "system.yaml"
    system.write_text(SYSTEM.format(name=path.name), encoding="utf-8")
    try:
        validate_in_process(system, repr(mutant))
        result = guarded("check_model", repr(mutant), lambda: api.check_model(path))
        check_diagnostics(result, repr(mutant))
        read_interface(path, mutant)
    finally:
        path.unlink(missing_ok=True)


@given(mutant=MUTATED_SSPS)
@fuzz_settings(100)
def test_mutated_ssp_archives_end_in_diagnostics(
    folder: Path, fuzz_cache: Path, mutant: Mutant
) -> None:
    """A corrupt or hostile SSP (the archive, its SSD, or one of the FMUs inside it), read by
    the SSP front end: diagnostics, never a traceback; nothing is left outside the cache."""
    path = write(folder, mutant.data, ".ssp")
    try:
        validate_in_process(path, repr(mutant))
        # The hostile member names climb at most three levels from an unpacked entry.
        for place in (fuzz_cache / "ssp", fuzz_cache, fuzz_cache.parent, folder):
            assert not (place / "escaped.txt").exists(), (place, mutant)
        assert not Path("/fmionnx-fuzz-absolute.txt").exists()
    finally:
        path.unlink(missing_ok=True)
        # Keep the unpack cache small over thousands of examples (make fuzz).
        for entry in (fuzz_cache / "ssp").glob("*"):
            shutil.rmtree(entry, ignore_errors=True)
