"""A study of an SSP system and the compile cache: a study of an archive keeps its plan (the
archive, with its ``.ssv`` files inside, is hashed); a study of a loose ``.ssd`` file is
compiled every time, since the ``.ssv`` and ``.ssm`` files beside it are read by its compile
and listed by no entry."""

from __future__ import annotations

import shutil
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx.pipeline import compilecache
from fmionnx.pipeline.sweep import plan_study
from tests.conftest import let_files_settle
from tests.ssp.conftest import CTRL_SSM, CTRL_SSV, FOREIGN_SSD, GAIN1_SSV, write_ssp

STUDY = "fmionnx: 1\nsystem: {system}\nparameters:\n  run.stop: [1, 2]\n"
FIVE = GAIN1_SSV.replace('value="3"', 'value="5"')


def _gain1_k(study: Path) -> float:
    plan, _ = plan_study(study)
    (k,) = (p.value for p in plan.system.component("gain1").parameters if p.port == "k")
    return float(k[0])


@pytest.fixture
def loose_ssd(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    """:data:`FOREIGN_SSD` unpacked: the SSD file, its FMUs and its ``.ssv``/``.ssm`` files."""
    resources = tmp_path / "loose" / "resources"
    resources.mkdir(parents=True)
    (resources.parent / "SystemStructure.ssd").write_text(FOREIGN_SSD, encoding="utf-8")
    shutil.copy(fixture_fmu("Integrator"), resources / "0001_integ.fmu")
    shutil.copy(fixture_fmu("Gain"), resources / "0002_gain1.fmu")
    shutil.copy(fixture_fmu("Gain"), resources / "0003_gain2.fmu")
    (resources / "gain1.ssv").write_text(GAIN1_SSV, encoding="utf-8")
    (resources / "ctrl.ssv").write_text(CTRL_SSV, encoding="utf-8")
    (resources / "ctrl.ssm").write_text(CTRL_SSM, encoding="utf-8")
    study = resources.parent / "study.yaml"
    study.write_text(STUDY.format(system="SystemStructure.ssd"), encoding="utf-8")
    let_files_settle()
    return study


def test_a_study_of_a_loose_ssd_sees_a_changed_parameter_file(
    loose_ssd: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    assert _gain1_k(loose_ssd) == 3.0
    (loose_ssd.parent / "resources" / "gain1.ssv").write_text(FIVE, encoding="utf-8")
    let_files_settle()
    assert _gain1_k(loose_ssd) == 5.0
    assert _kept_plans(tmp_path) == 0  # no plan of a study of a loose SSD is kept


def _kept_plans(tmp_path: Path) -> int:
    """How many of the cache's entries hold a study's plan."""
    root = tmp_path / "cache" / "compiled"
    if not root.exists():
        return 0
    entries = [p / compilecache.ENTRY for p in root.iterdir() if not p.name.startswith(".")]
    return sum(b'"payload":{' in e.read_bytes() for e in entries if e.is_file())


def test_a_study_of_an_archive_is_kept_and_sees_a_rebuilt_archive(
    foreign_ssp: Path, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from fmionnx.compile import study as study_compiler

    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    compiles: list[object] = []
    real = study_compiler.compile_study
    monkeypatch.setattr(
        study_compiler, "compile_study", lambda *a, **k: compiles.append(a) or real(*a, **k)
    )
    study = foreign_ssp.parent / "study.yaml"
    study.write_text(STUDY.format(system=foreign_ssp.name), encoding="utf-8")
    let_files_settle()
    # The first compile unpacks the archive, whose files are then newer than the compile's
    # start: not kept (as any file changed during a compile); the second one is, once the
    # unpacked files are older than the cache's margin (a quick first compile left the
    # second within it, and that one was not kept either).
    assert _gain1_k(study) == 3.0
    let_files_settle()
    for _ in range(2):
        assert _gain1_k(study) == 3.0
    assert len(compiles) == 2
    assert _kept_plans(tmp_path) == 1
    members = {}
    with zipfile.ZipFile(foreign_ssp) as archive:
        for name in archive.namelist():
            members[name] = archive.read(name)
    members["resources/gain1.ssv"] = FIVE.encode()
    write_ssp(foreign_ssp, members)
    let_files_settle()
    assert _gain1_k(study) == 5.0
    assert len(compiles) == 3
