"""``--resume`` trusts finished cases only when the plan that ran them is the same: the plan's
fingerprint covers what decides a case's row, including the system's checks (its pass/fail
columns) and output interval (the rows its metrics measure), which the system's content hash
leaves out because they do not change what is simulated."""

from __future__ import annotations

from pathlib import Path

from fmionnx.pipeline.sweep import plan_study
from tests.sweep.conftest import WriteStudy

STUDY = "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: [1, 2]\n"


def _fingerprint(study: Path) -> tuple[str, str]:
    plan = plan_study(study)[0]
    return plan.fingerprint, plan.system.content_hash


def _edit_system(folder: Path, old: str, new: str) -> None:
    system = folder / "system.yaml"
    text = system.read_text(encoding="utf-8")
    assert old in text
    system.write_text(text.replace(old, new), encoding="utf-8")


def test_a_changed_check_bound_changes_the_fingerprint(write_study: WriteStudy) -> None:
    study = write_study(STUDY)
    before, system_before = _fingerprint(study)
    assert _fingerprint(study)[0] == before  # stable
    _edit_system(study.parent, "final(gain.y) < 3", "final(gain.y) < 4")
    after, system_after = _fingerprint(study)
    assert system_after == system_before  # the simulation is the same ...
    assert after != before  # ... but the cases' check columns are not


def test_a_changed_output_interval_changes_the_fingerprint(write_study: WriteStudy) -> None:
    study = write_study(STUDY)
    before = _fingerprint(study)[0]
    _edit_system(
        study.parent,
        "run: {stop: 1, step: 0.01}",
        "run: {stop: 1, step: 0.01, output_interval: 0.1}",
    )
    assert _fingerprint(study)[0] != before
