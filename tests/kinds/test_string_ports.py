"""String ports (issue: a bug hunt): a String -> String connection passed `validate`, then
every run ended in a traceback (`a.text is not a numeric output`); a `record:` entry naming a
string output was left out of results.csv without a word.

Both are refused at compile time with E025, located at the entry; a string set as a parameter
(once, at setup) still reaches the model, and the default recording leaves strings out.
``Strings2`` is a real FMI 2 FMU built from C: ``text = label + "|" + textIn``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.runtime.result import RunStatus
from tests.conftest import build_fixture_fmu


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``tmp_path`` as the working directory, so messages name `system.yaml`."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def _system(folder: Path, rest: str) -> Path:
    fmu = build_fixture_fmu("Strings2")
    path = folder / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: strings\nrun: {stop: 0.3, step: 0.1}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fmu}, parameters: {{label: hello}}}}\n"
        f"  b: {{kind: fmu, path: {fmu}}}\n{rest}",
        encoding="utf-8",
    )
    return path


def _validate(path: Path) -> tuple[int, list[tuple[str, int, int, str]]]:
    result = CliRunner().invoke(app, ["validate", str(path.name)])
    assert "Traceback" not in result.output
    pattern = r"^system\.yaml:(\d+):(\d+): error\[(\w+) [\w-]+\]: (.*)$"
    errors = [
        (code, int(line), int(col), message)
        for line, col, code, message in re.findall(pattern, result.output, flags=re.MULTILINE)
    ]
    return result.exit_code, errors


def test_a_string_connection_is_refused_at_the_connection(folder: Path) -> None:
    path = _system(folder, "connections:\n  - a.labelLength -> b.textIn\n  - a.text -> b.textIn\n")
    code, errors = _validate(path)
    assert code != 0
    e025 = [e for e in errors if e[0] == "E025"]
    assert len(e025) == 1
    assert e025[0][1:3] == (9, 5)
    assert "`a.text` -> `b.textIn` connects string ports" in e025[0][3]


def test_a_refused_string_connection_never_reaches_a_run(folder: Path) -> None:
    path = _system(folder, "connections:\n  - a.text -> b.textIn\n")
    result = CliRunner().invoke(app, ["run", path.name, "--no-out", "--isolate", "none"])
    assert result.exit_code != 0
    assert "E025" in result.output
    assert "Traceback" not in result.output
    assert "KeyError" not in result.output


def test_a_record_entry_naming_a_string_port_is_refused(folder: Path) -> None:
    path = _system(folder, "record: [a.labelLength, a.text]\n")
    code, errors = _validate(path)
    assert code != 0
    assert [(c, line, col) for c, line, col, _ in errors] == [("E025", 7, 25)]
    assert "`a.text` is a string port" in errors[0][3]


def test_strings_are_set_at_setup_and_left_out_of_the_default_recording(folder: Path) -> None:
    path = _system(folder, "")
    outcome = fmionnx.run(path, no_out=True, isolate="none", params={"b.textIn": "four"})
    result = outcome.result
    assert result.status is RunStatus.COMPLETED
    assert list(result.signals) == [
        "a.labelLength",
        "a.textInLength",
        "b.labelLength",
        "b.textInLength",
    ]
    assert result.signals["a.labelLength"][-1] == len("hello")
    assert result.signals["b.textInLength"][-1] == len("four")
