"""An element index inside a YAML flow collection gets a "quote the endpoint" hint (issue #16).

``{from: a.y, to: g.v[0]}`` is invalid YAML (``[`` opens a list inside ``{...}``); the bare
parser message does not say that quoting is the fix. The golden output is the corpus case
``tests/cases/invalid/flow-index``.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.spec.yaml_hints import flow_index_hint

GLUED = "expected ',' or '}', but got '['"
IN_SEQUENCE = "expected ',' or ']', but got '['"


@pytest.mark.parametrize(
    ("line", "problem", "endpoint"),
    [
        ("  - {from: a.y, to: g.v[0]}", GLUED, "g.v[0]"),
        ("  - {from: g.w[2], to: b.u}", GLUED, "g.w[2]"),
        ("connections: [a.w[0] -> g.u]", IN_SEQUENCE, "a.w[0] -> g.u"),
        ("  - {y: [a.w[1], g.y]}", IN_SEQUENCE, "a.w[1]"),
        ("  - {y: [a.w[0,2]]}", IN_SEQUENCE, "a.w[0,2]"),
        ("  - {from: a.y, to: g.v[0]}  # comment", GLUED, "g.v[0]"),
    ],
)
def test_the_hint_quotes_the_whole_endpoint(line: str, problem: str, endpoint: str) -> None:
    column = line.index("[", line.index(endpoint))
    hint = flow_index_hint(line, 0, column, problem)
    assert hint is not None
    assert hint.startswith(f"quote the endpoint: '{endpoint}' (")


@pytest.mark.parametrize(
    ("line", "column", "problem"),
    [
        ("  - {a: [1] [2]}", 12, GLUED),  # a list after a space: another mistake
        ("  - {a: b c}", 9, "expected ',' or '}', but got '<scalar>'"),
        ("  - {from: a.y, to: g.v[0]}", 99, GLUED),  # a mark beyond the line
        ("  - {from: a.y, to: g.v[0]}", 5, GLUED),  # the mark is not at a `[`
    ],
)
def test_other_errors_get_no_hint(line: str, column: int, problem: str) -> None:
    assert flow_index_hint(line, 0, column, problem) is None


SYSTEM = """\
fmionnx: 1
name: flow
run: {{stop: 0.1, step: 0.01}}
components:
  a: {{kind: fmu, path: Gain.fmu}}
  g: {{kind: fmu, path: Gain.fmu}}
connections:
  - {{from: a.y, to: {endpoint}}}
"""


def test_quoting_as_the_hint_says_makes_the_file_valid(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    path = tmp_path / "system.yaml"
    path.write_text(SYSTEM.format(endpoint="g.v[0]"), encoding="utf-8")
    (error,) = [d for d in api.compile_system(path).diagnostics if d.code == "E001"]
    assert error.hint is not None
    assert "'g.v[0]'" in error.hint
    path.write_text(SYSTEM.format(endpoint="'g.v[0]'"), encoding="utf-8")
    assert api.compile_system(path).ok
