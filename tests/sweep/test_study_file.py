"""Study files with mistakes: every problem at its ``file:line:col`` with its code and a
suggestion, exit 1, nothing written. And the study file's JSON Schema is the committed one."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.cli.schema_cmd import schema_text
from tests.conftest import REPO
from tests.sweep.conftest import WriteStudy

MISTAKES = """\
fmionnx: 1
system: system.yaml
parameters:
  gain.kk: [1, 2]
  gian.k: [1]
  run.stopp: [1]
  integ.x0: {range: {start: 0, stop: 1, num: 2}}
metrics:
  y: final(gain.yy)
  z: final(gain.y) < 2
  small: max(gain.y)
objective: {minimize: yy}
"""


def _sweep(study: Path, out: Path) -> tuple[int, str]:
    result = CliRunner().invoke(
        app, ["sweep", str(study), "--out", str(out)], env={"COLUMNS": "200", "NO_COLOR": "1"}
    )
    return result.exit_code, result.output


def _errors(output: str) -> list[str]:
    """The error lines, with the file's folder left out."""
    return [line.split("/")[-1] for line in output.splitlines() if ": error[" in line]


def test_every_mistake_is_reported_at_its_place(write_study: WriteStudy, tmp_path: Path) -> None:
    study = write_study(MISTAKES)
    code, output = _sweep(study, tmp_path / "out")
    assert code == 1
    assert _errors(output) == [
        "study.yaml:4:3: error[E102 study-target]: `gain.kk`: `gain` has no parameter `kk`",
        "study.yaml:5:3: error[E102 study-target]: `gian.k`: the system has no component `gian`",
        "study.yaml:6:3: error[E102 study-target]: `run.stopp` is not a run setting a study can vary",
        "study.yaml:9:12: error[E091 check-signal]: metric `y`: component `gain` (fmu) has no port `yy`",
        "study.yaml:10:6: error[E093 check-meaning]: metric `z`: a metric is a measure (one number), "
        "not a comparison",
        "study.yaml:11:3: error[E104 study-metric]: metric `small` has the name of one of the "
        "system's checks",
        "study.yaml:12:23: error[E105 study-objective]: the objective names no metric `yy`",
    ]
    hints = [line.strip() for line in output.splitlines() if line.strip().startswith("hint:")]
    assert hints[:3] == [
        "hint: did you mean `k`?",
        "hint: did you mean `gain`?",
        "hint: did you mean `run.stop`?",
    ]
    assert not (tmp_path / "out").exists()  # nothing written


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: [1, x]\n",
            "study.yaml:4:11: error[E103 study-values]: `gain.k`: expected 1 value(s) of type "
            "float64 (shape scalar), got `x`",
        ),
        (
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  run.stop: [0.123]\n",
            "study.yaml:4:13: error[E103 study-values]: `run.stop`: run.stop 0.123 is not a whole "
            "number of base steps (0.01 s) after the start",
        ),
        (  # found by fuzzing: `true` was taken for the `1` before it and never checked
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: [0.5, 1, true]\n",
            "study.yaml:4:11: error[E103 study-values]: `gain.k`: expected 1 value(s) of type "
            "float64 (shape scalar), got `True`",
        ),
        (  # found by fuzzing: an assertion error (a traceback) in `fmionnx validate`
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  run.output_interval: [0.02, [1, 0]]\n",
            "study.yaml:4:24: error[E103 study-values]: `run.output_interval`: run.output_interval "
            "[1, 0] must be a finite number of seconds",
        ),
        (
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  run.stop: [true]\n",
            "study.yaml:4:13: error[E103 study-values]: `run.stop`: run.stop true must be a finite "
            "number of seconds",
        ),
        (
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: {random: {low: 0, high: 1}}\n",
            "study.yaml:4:11: error[E103 study-values]: `gain.k` is sampled, but the study has no "
            "`sampling: {samples: N, seed: S}`",
        ),
        (
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: {random: {low: 1, high: 0}}\n"
            "sampling: {samples: 2}\n",
            "study.yaml:4:20: error[E003 invalid-value]: `parameters.gain.k.random`: `high` (0) "
            "must be greater than `low` (1) ...",
        ),
        (  # found by fuzzing: an OSError traceback
            f"fmionnx: 1\nsystem: {'9' * 300}.yaml\nparameters:\n  gain.k: [1]\n",
            f"study.yaml:2:9: error[E101 study-system]: the study's system file `{'9' * 300}.yaml` "
            "cannot be read: File name too long",
        ),
        (
            "fmionnx: 1\nsystem: nowhere.yaml\nparameters:\n  gain.k: [1]\n",
            "study.yaml:2:9: error[E101 study-system]: the study's system file `nowhere.yaml` does "
            "not exist",
        ),
        (
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: {range: {start: 0, stop: 1, "
            "num: 2000}}\n  integ.x0: {range: {start: 0, stop: 1, num: 1000}}\n",
            "study.yaml:3:1: error[E106 study-size]: the study has 2000000 cases, more than 1000000",
        ),
        (  # a bug hunt: ignored, two cases instead of the six meant
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: [1, 2]\n"
            "sampling: {samples: 3, seed: 1}\n",
            "study.yaml:5:1: error[E103 study-values]: `sampling` draws the rows of sampled "
            "targets, and no target is sampled",
        ),
        (  # a bug hunt: "does not exist"
            "fmionnx: 1\nsystem: .\nparameters:\n  gain.k: [1]\n",
            "study.yaml:2:9: error[E101 study-system]: the study's system file `.` is a folder, "
            "not a system file",
        ),
        (  # a bug hunt: accepted, `none` given with `fmus` (the CLI's --isolate the same)
            "fmionnx: 1\nsystem: system.yaml\nparameters:\n  gain.k: [1]\nisolate: [none, fmus]\n",
            "study.yaml:5:10: error[E102 study-target]: `isolate`: `none` stands alone: it cannot "
            "be given with `fmus`, `all` or a component",
        ),
        (
            "fmionnx: 1\nsystem: system.yaml\nparameter:\n  gain.k: [1]\n",
            "study.yaml:3:1: error[E002 unknown-key]: unknown key `parameter` in the top level",
        ),
        (
            "fmionnx: 1\nname: chain\ncomponents: {}\n",
            "study.yaml:1:1: error[E100 study-file]: a study file is a mapping with keys `fmionnx`, "
            "`system`, `parameters` ...",
        ),
    ],
)
def test_one_mistake(write_study: WriteStudy, tmp_path: Path, text: str, expected: str) -> None:
    code, output = _sweep(write_study(text), tmp_path / "out")
    assert code == 1
    errors = _errors(output)
    if expected.endswith(" ..."):
        assert [e for e in errors if e.startswith(expected.removesuffix(" ..."))], output
    else:
        assert expected in errors, output
    assert len(errors) == 1 or "E002" in expected, output  # with E002: E004 for `parameters`


def test_a_missing_study_file(tmp_path: Path) -> None:
    code, output = _sweep(tmp_path / "none.yaml", tmp_path / "out")
    assert code == 1
    assert "error[E100 study-file]: study file" in output
    assert "does not exist" in output


def test_the_committed_study_schema_is_current() -> None:
    committed = (REPO / "schemas" / "study.schema.json").read_text(encoding="utf-8")
    assert committed == schema_text(study=True), "run `make schema` and commit the schemas"
