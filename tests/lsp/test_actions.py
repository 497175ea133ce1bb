"""Fixes for a factor that repeats the automatic unit conversion (W033), in-process: in the
flow form and in the block form of a connection, the edits give the file the fix describes,
and the fixed file checks without the warning."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from lsprotocol import types

from fmionnx.core.sourcetext import source_lines
from fmionnx.lsp.actions import actions
from fmionnx.lsp.analysis import analyse
from fmionnx.lsp.diagnostics import Published, convert
from tests.lsp.client import apply

HEAD = (
    "fmionnx: 1\nname: repeated\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
    "  src: {kind: signal, outputs: {a: {constant: 1, unit: km}}}\n"
    "  gain: {kind: fmu, path: Gain.fmu, parameters: {v: [0, 0, 0]}}\nconnections:\n"
)
FLOW = "  - {from: src.a, to: gain.u, factor: 1000, offset: 0}\n"
BLOCK = "  - from: src.a\n    to: gain.u\n    factor: 1000\n    offset: 0\n"
URI = "file:///repeated.yaml"
EVERYWHERE = types.Range(types.Position(line=0, character=0), types.Position(line=99, character=0))


def _published(path: Path, text: str) -> list[Published]:
    analysis = analyse(path, {path: text})
    lines = {path: text.split("\n")}
    return convert(analysis, lambda f: lines.get(f) or source_lines(f))[path]


@pytest.mark.parametrize(
    ("written", "dropped", "unconverted"),
    [
        (
            FLOW,
            "  - {from: src.a, to: gain.u}\n",
            "  - {from: src.a, to: gain.u, factor: 1000, offset: 0, convert_units: false}\n",
        ),
        (
            BLOCK,
            "  - from: src.a\n    to: gain.u\n",
            BLOCK + "    convert_units: false\n",
        ),
    ],
    ids=["flow", "block"],
)
def test_a_repeated_conversion_is_dropped_or_kept_alone(
    tmp_path: Path,
    fixture_fmu: Callable[[str], Path],
    written: str,
    dropped: str,
    unconverted: str,
) -> None:
    shutil.copy(fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    path = tmp_path / "system.yaml"
    text = HEAD + written
    published = _published(path, text)
    assert [p.lsp.code for p in published] == ["I033", "W033"]
    found = actions(URI, path, text, published, EVERYWHERE)
    assert [a.title for a in found] == [
        "Drop `factor`/`offset`: fmionnx converts the units",
        "Keep only your factor/offset (`convert_units: false`)",
    ]
    results = []
    for action in found:
        assert action.edit is not None
        assert action.edit.changes is not None
        results.append(apply(text, action.edit.changes[URI]))
    assert results == [HEAD + dropped, HEAD + unconverted]
    for fixed in results:
        assert "W033" not in [p.lsp.code for p in _published(path, fixed)]
