"""A backend is one module plus its entry in the backend table (``pipeline/backends.py``).

This module is such a module: :class:`SequentialBackend`, with an options type of its own,
becomes reachable from the Python API and the CLI by one table entry, and gets everything
the pipeline does around a backend (option checks with the CLI's messages, overrides,
checks, results files, exit status) without an edit anywhere else.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Self

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli import app
from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.diagnostics import Diagnostic
from fmionnx.pipeline import backends
from fmionnx.pipeline.errors import RequestError
from fmionnx.runtime.backend import Backend, BackendOptions, OptionsError
from fmionnx.runtime.result import RunOptions, RunResult, RunStatus
from tests.ros2.test_run import loop_system

CHECKS = """
checks:
  - name: gain holds
    expect: final(gain.y) < 10
"""


@dataclasses.dataclass(frozen=True)
class SequentialOptions(BackendOptions):
    """One option of its own: a label written to run.json."""

    label: str = "plain"

    @classmethod
    def checked(cls, given: Mapping[str, object]) -> Self:
        label = given.get("label", "plain")
        if not isinstance(label, str) or not label:
            msg = f"--label takes a word, not `{label}`"
            raise OptionsError(msg)
        return cls(label=label)

    def details(self) -> dict[str, str | bool]:
        return {"label": self.label}


class SequentialBackend(Backend):
    """Every step on one thread, nothing isolated: the master, run plainly."""

    name = "sequential"
    summary = "the master on one thread"
    options_type = SequentialOptions

    def validate(self, system: CompiledSystem, options: BackendOptions) -> list[Diagnostic]:
        return []

    def run(self, system: CompiledSystem, options: BackendOptions, run: RunOptions) -> RunResult:
        from fmionnx.runtime.master import Master

        result = Master(system, dataclasses.replace(run, schedule="sequential")).run()
        result.details.update(options.details())
        result.backend = self.name
        return result


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    """The one line a new backend adds."""
    monkeypatch.setitem(backends.BACKENDS, "sequential", f"{__name__}:SequentialBackend")


def _system(folder: Path) -> Path:
    path = loop_system(folder, 0.5)
    path.write_text(path.read_text(encoding="utf-8") + CHECKS, encoding="utf-8")
    return path


def test_a_new_backend_runs_from_python_with_its_own_options(
    tmp_path: Path, registered: None
) -> None:
    system = _system(tmp_path)
    outcome = fmionnx.run(
        system, backend="sequential", label="seam", stop_time=0.2, out=tmp_path / "out"
    )
    assert outcome.status is RunStatus.COMPLETED
    assert outcome.result.steps_done == 20  # the pipeline's overrides applied
    assert [check.name for check in outcome.checks] == ["gain holds"]  # and its checks
    info = json.loads((tmp_path / "out" / "run.json").read_text(encoding="utf-8"))
    assert info["backend"] == "sequential"
    assert info["execution"]["label"] == "seam"
    plain = fmionnx.run(system, stop_time=0.2, no_out=True, isolate="none")
    for name, values in plain.result.signals.items():
        assert np.array_equal(outcome.result.signals[name], values), name


def test_a_new_backend_gets_the_pipelines_option_rules(tmp_path: Path, registered: None) -> None:
    system = _system(tmp_path)
    with pytest.raises(
        RequestError, match="--sync applies to --backend ros2, not to --backend sequential"
    ):
        fmionnx.run(system, backend="sequential", sync="free", no_out=True)
    with pytest.raises(RequestError, match="--colour does not apply to --backend sequential"):
        fmionnx.run(system, backend="sequential", colour="red", no_out=True)  # type: ignore[call-arg]
    with pytest.raises(RequestError, match="--label takes a word, not ``"):
        fmionnx.run(system, backend="sequential", label="", no_out=True)


def test_a_new_backend_runs_from_the_cli(tmp_path: Path, registered: None) -> None:
    out = tmp_path / "out"
    result = CliRunner().invoke(
        app, ["run", str(_system(tmp_path)), "--backend", "sequential", "-q", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert json.loads((out / "run.json").read_text(encoding="utf-8"))["backend"] == "sequential"


def test_without_its_entry_the_backend_is_unknown(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["run", str(_system(tmp_path)), "--backend", "sequential"])
    assert result.exit_code == 2
    assert "--backend must be `inprocess` or `ros2`, not `sequential`" in result.output
