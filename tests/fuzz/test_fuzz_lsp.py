"""Fuzzing the language server's own code: any text, half-typed or mangled, with the cursor
anywhere, gets answers (possibly empty) from completion, hover, definition, fixes and rename,
never an exception (issue 36: bad input never stops the server).

The compiler's reading of mutated system files is fuzzed by ``test_fuzz_yaml``; this fuzzes
what the server adds: where the cursor is, the lenient outline, ranges, the features. The
seed is the reference system with its real model interfaces (read once).
"""

from __future__ import annotations

import contextlib
import functools
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from lsprotocol import types

from fmionnx.core.diagnostics import Diagnostic, Span
from fmionnx.lsp.actions import actions
from fmionnx.lsp.analysis import DocumentKind
from fmionnx.lsp.completion import complete
from fmionnx.lsp.definition import definition
from fmionnx.lsp.diagnostics import Published
from fmionnx.lsp.hover import hover
from fmionnx.lsp.outline import Outline, outline_yaml
from fmionnx.lsp.positions import span_range
from fmionnx.lsp.rename import RenameError, component_at, rename
from fmionnx.lsp.ssd import complete_ssd, definition_ssd, hover_ssd
from fmionnx.lsp.yamlcontext import cursor_at
from tests.conftest import REPO
from tests.fuzz.harness import fuzz_settings
from tests.fuzz.mutations import mutate_text

REFERENCE = REPO / "systems" / "sign_follower.yaml"
TEXT = REFERENCE.read_text(encoding="utf-8")
HINTS = ("did you mean `theta`?", "quote the endpoint: 'a.b[0]' (inside", None, "drop `factor`")


@functools.cache
def reference_outline() -> Outline:
    """The reference system's outline, its interfaces read from the built models."""
    return outline_yaml(REFERENCE, TEXT)


@st.composite
def typed(draw: st.DrawFn) -> tuple[str, int, int]:
    """The reference system mangled, cut where a user is typing, and a cursor position."""
    text = mutate_text(draw, TEXT)
    lines = text.split("\n")
    row = draw(st.integers(0, len(lines) - 1))
    cut = draw(st.integers(0, len(lines[row])))
    if draw(st.booleans()):  # the line as it is while being typed
        lines[row] = lines[row][:cut]
    column = draw(st.integers(0, len(lines[row]) + 2))
    return "\n".join(lines), row, column


@pytest.mark.parametrize("kind", [DocumentKind.SYSTEM, DocumentKind.STUDY])
@fuzz_settings(25)
@given(case=typed())
def test_every_feature_answers_any_text_at_any_position(
    kind: DocumentKind, case: tuple[str, int, int]
) -> None:
    text, line, column = case
    outline = reference_outline()
    cursor_at(text, line, column)
    assert isinstance(complete(text, line, column, kind, outline), list)
    hover(text, line, column, kind, outline, ("E021",))
    assert isinstance(definition(text, line, column, kind, outline), list)
    component_at(REFERENCE, text, line, column)
    with contextlib.suppress(RenameError):  # a refusal is an answer
        rename("file:///x.yaml", REFERENCE, text, line, column, "renamed")
    outline_yaml(REFERENCE, text)


@fuzz_settings(40)
@given(
    case=typed(),
    span=st.tuples(st.integers(-1, 90), st.integers(-1, 120)),
    hint=st.sampled_from(HINTS),
    code=st.sampled_from(("E021", "E033", "W033", "E001", "E030")),
)
def test_ranges_and_fixes_of_any_diagnostic_never_fail(
    case: tuple[str, int, int], span: tuple[int, int], hint: str | None, code: str
) -> None:
    text, _, _ = case
    lines = text.split("\n")
    where = Span(Path("x.yaml"), *span)
    found = span_range(where, lines, code=code)
    assert found.start.line >= 0
    assert found.start.character <= found.end.character or found.start.line != found.end.line
    published = [
        Published(types.Diagnostic(found, "m", code=code), Diagnostic(code, "m", where, hint))
    ]
    everything = types.Range(
        types.Position(line=0, character=0), types.Position(line=10**6, character=0)
    )
    assert isinstance(actions("file:///x.yaml", REFERENCE, text, published, everything), list)


SSD_TEXT = (REPO / "examples" / "ssp-roundtrip" / "vendor" / "SystemStructure.ssd").read_text(
    encoding="utf-8"
)


@fuzz_settings(40)
@given(data=st.data())
def test_ssd_features_answer_any_text_at_any_position(data: st.DataObject) -> None:
    text = mutate_text(data.draw, SSD_TEXT)
    lines = text.split("\n")
    line = data.draw(st.integers(0, len(lines) - 1))
    column = data.draw(st.integers(0, len(lines[line]) + 2))
    outline = reference_outline()
    assert isinstance(complete_ssd(text, line, column, outline), list)
    hover_ssd(text, line, column, outline)
    definition_ssd(text, line, column, outline)
