"""The language server on ports whose names are no dotted word, written quoted (a bug hunt).

PyTorch's ONNX export names ports ``input.1`` and ``12``; an endpoint names them quoted,
``p."input.1"``, ``p."12"[0]`` (docs/system-file.md). The server's names stopped at the
quote: hover and go to definition found nothing on ``p."12"``, completion offered ``12`` and
``a b`` bare (which do not compile), renaming a component ``x`` edited the ``x`` inside
``q."x y"``, an unknown quoted port was underlined to its first blank, and the fix of a
misspelt quoted port broke it. The models are real ONNX graphs (those of the compiler's own
test), checked in-process as the server checks them; one test goes through the server.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from lsprotocol import types
from pygls.uris import to_fs_path

from fmionnx.core.diagnostics import Severity
from fmionnx.core.sourcetext import source_lines
from fmionnx.lsp.actions import actions
from fmionnx.lsp.analysis import Analysis, DocumentKind, analyse
from fmionnx.lsp.completion import complete
from fmionnx.lsp.definition import definition
from fmionnx.lsp.diagnostics import Published, convert
from fmionnx.lsp.hover import hover
from fmionnx.lsp.rename import RenameError, component_at, rename
from tests.compile.test_quoted_port_names import _models
from tests.lsp.client import Session, apply

SYSTEM = """\
fmionnx: 1
name: quoted
run: {stop: 0.2, step: 0.1}
components:
  p: {kind: onnx, path: p.onnx}
  q: {kind: onnx, path: q.onnx}
  x: {kind: signal, outputs: {v: {constant: 1}}}
inputs:
  k: {to: [p."input.1"], value: 2.5}
connections:
  - p."12"[1] -> q."x y"
  - {from: p."a b", to: q.z}
record: [p."12", 'q."x y"', q.out, x.v]
plots:
  - {y: [p."a b", 'p."12"[1]'], title: quoted}
checks:
  - name: sums
    expect: final(`q."x y"`[0]) + final(`p."a b"`[0]) - final(q.out[0]) == 0
"""
CONNECTION = '  - p."12"[1] -> q."x y"'
EXPECT = '    expect: final(`q."x y"`[0]) + final(`p."a b"`[0]) - final(q.out[0]) == 0'
URI = "file:///quoted.yaml"
EVERYWHERE = types.Range(types.Position(line=0, character=0), types.Position(line=99, character=0))


def _checked(folder: Path, text: str = SYSTEM) -> tuple[Path, Analysis]:
    _models(folder)
    path = folder / "system.yaml"
    path.write_text(text, encoding="utf-8")
    return path, analyse(path, {path: text})


def _position(text: str, line_part: str, inside: str, offset: int = 0) -> tuple[int, int]:
    """0-based line and column of ``inside`` (plus ``offset``) on the line holding
    ``line_part``."""
    for number, line in enumerate(text.split("\n")):
        if line_part in line:
            return number, line.index(inside) + offset
    raise AssertionError(line_part)


def _errors(folder: Path, text: str) -> list[str]:
    return [
        f"{d.code} {d.message}"
        for d in _checked(folder, text)[1].diagnostics
        if d.severity is Severity.ERROR
    ]


def _edits(edit: types.WorkspaceEdit | None) -> list[types.TextEdit]:
    assert edit is not None
    assert edit.changes is not None
    return list(edit.changes[URI])


def _published(path: Path, text: str) -> list[Published]:
    analysis = analyse(path, {path: text})
    lines = {path: text.split("\n")}
    return convert(analysis, lambda f: lines.get(f) or source_lines(f))[path]


#: (the line, the text the cursor is in, the port as hover names it)
NAMED = [
    (CONNECTION, '"12"', 'p."12"'),
    (CONNECTION, '"x y"', 'q."x y"'),
    ('{from: p."a b"', '"a b"', 'p."a b"'),
    ("record:", '"x y"', 'q."x y"'),
    ("  k: {to:", "input.1", 'p."input.1"'),
    ("  - {y: [", '"12"', 'p."12"'),
    ("expect:", '"a b"', 'p."a b"'),
]


@pytest.mark.parametrize(("line_part", "inside", "named"), NAMED)
def test_hover_and_definition_find_a_quoted_port_wherever_it_is_named(
    tmp_path: Path, line_part: str, inside: str, named: str
) -> None:
    _, analysis = _checked(tmp_path)
    assert [d.code for d in analysis.diagnostics if d.severity is Severity.ERROR] == []
    line, column = _position(SYSTEM, line_part, inside, 2)
    shown = hover(SYSTEM, line, column, DocumentKind.SYSTEM, analysis.outline)
    assert shown is not None
    assert isinstance(shown.contents, types.MarkupContent)
    assert shown.contents.value.startswith(f"**{named}** — ")
    assert shown.range is not None
    written = SYSTEM.split("\n")[line][shown.range.start.character : shown.range.end.character]
    assert written.startswith(named)  # the whole name, its quotes (and an index) included
    (location,) = definition(SYSTEM, line, column, DocumentKind.SYSTEM, analysis.outline)
    page = Path(str(to_fs_path(location.uri))).read_text(encoding="utf-8").split("\n")
    port = named.split(".", 1)[1].strip('"')
    assert page[location.range.start.line].strip().startswith(f"{port}:")


@pytest.mark.parametrize(
    ("written", "cursor", "label", "fixed"),
    [
        # after `p.`, before anything: the port is inserted quoted
        ('  - p. -> q."x y"', "  - p.", '"a b"', '  - p."a b" -> q."x y"'),
        # an opening quote typed: it is replaced, not doubled
        ('  - p."1[1] -> q."x y"', '  - p."1', '"12"', CONNECTION),
        # inside a quoted name: the whole of it is replaced, its tail not left behind
        ('  - p."1"[0] -> q."x y"', '  - p."', '"a b"', '  - p."a b"[0] -> q."x y"'),
        ('  - p."12"[1] -> q.', '  - p."12"[1] -> q.', '"x y"', CONNECTION),
    ],
)
def test_completion_inserts_a_port_that_is_no_dotted_word_quoted(
    tmp_path: Path, written: str, cursor: str, label: str, fixed: str
) -> None:
    _, analysis = _checked(tmp_path)
    text = SYSTEM.replace(CONNECTION, written)
    line = text.split("\n").index(written)
    items = complete(text, line, len(cursor), DocumentKind.SYSTEM, analysis.outline)
    (item,) = [i for i in items if i.label == label]
    assert isinstance(item.text_edit, types.TextEdit)
    completed = apply(text, [item.text_edit])
    assert completed == SYSTEM.replace(CONNECTION, fixed)
    assert _errors(tmp_path, completed) == []


def test_completion_in_a_record_list_and_a_system_input_quotes_too(tmp_path: Path) -> None:
    _, analysis = _checked(tmp_path)
    for written, cursor, label in [
        ("record: [p., q.out]", "record: [p.", '"12"'),
        ("  k: {to: [p.], value: 2.5}", "  k: {to: [p.", '"input.1"'),
    ]:
        original = next(ln for ln in SYSTEM.split("\n") if ln.startswith(written[:8]))
        text = SYSTEM.replace(original, written)
        line = text.split("\n").index(written)
        items = complete(text, line, len(cursor), DocumentKind.SYSTEM, analysis.outline)
        (item,) = [i for i in items if i.label == label]
        assert isinstance(item.text_edit, types.TextEdit)
        assert _errors(tmp_path, apply(text, [item.text_edit])) == []


def test_a_parameter_key_is_still_the_port_name_as_the_model_writes_it(tmp_path: Path) -> None:
    """Where a parameter is named, not an endpoint, the name is not quoted."""
    _, analysis = _checked(tmp_path)
    text = SYSTEM.replace(
        "  p: {kind: onnx, path: p.onnx}",
        "  p:\n    kind: onnx\n    path: p.onnx\n    units:\n      ",
    )
    line = text.split("\n").index("      ")
    items = complete(text, line, 6, DocumentKind.SYSTEM, analysis.outline)
    assert {"input.1", "12", "a b"} <= {i.label for i in items}


@pytest.mark.parametrize(
    ("written", "cursor", "fixed"),
    [
        # outside backticks: the whole name goes between them
        ("final(q.[0]) == 0", "final(q.", 'final(`q."x y"`[0]) == 0'),
        # inside backticks already: the quoted port only
        ("final(`q.`[0]) == 0", "final(`q.", 'final(`q."x y"`[0]) == 0'),
        ('final(`q."x`[0]) == 0', 'final(`q."x', 'final(`q."x y"`[0]) == 0'),
    ],
)
def test_completion_in_a_check_writes_a_quoted_port_between_backticks(
    tmp_path: Path, written: str, cursor: str, fixed: str
) -> None:
    _, analysis = _checked(tmp_path)
    text = SYSTEM.replace(EXPECT, f"    expect: {written}")
    line = text.split("\n").index(f"    expect: {written}")
    column = len("    expect: ") + len(cursor)
    items = complete(text, line, column, DocumentKind.SYSTEM, analysis.outline)
    (item,) = [i for i in items if i.label == '"x y"']
    assert isinstance(item.text_edit, types.TextEdit)
    completed = apply(text, [item.text_edit])
    assert completed == SYSTEM.replace(EXPECT, f"    expect: {fixed}")
    assert _errors(tmp_path, completed) == []


def test_renaming_a_component_keeps_quoted_port_names_intact(tmp_path: Path) -> None:
    path, _ = _checked(tmp_path)
    line, column = _position(SYSTEM, "  x: {kind", "x")
    renamed = apply(SYSTEM, _edits(rename(URI, path, SYSTEM, line, column, "src")))
    # the `x` of `q."x y"` is the port's, not the component's
    assert renamed == SYSTEM.replace("  x: {kind", "  src: {kind").replace("x.v]", "src.v]")
    line, column = _position(SYSTEM, CONNECTION, "p")
    renamed = apply(SYSTEM, _edits(rename(URI, path, SYSTEM, line, column, "net")))
    assert renamed == SYSTEM.replace('p."', 'net."').replace("  p: {kind", "  net: {kind")
    assert _errors(tmp_path, renamed) == []


def test_a_quoted_port_under_the_cursor_is_no_component_to_rename(tmp_path: Path) -> None:
    path, _ = _checked(tmp_path)
    line, column = _position(SYSTEM, CONNECTION, '"x y"', 1)  # on the `x` of the port
    assert component_at(path, SYSTEM, line, column) is None
    with pytest.raises(RenameError):
        rename(URI, path, SYSTEM, line, column, "src")


def test_an_unknown_quoted_port_is_underlined_whole_and_its_fix_stays_quoted(
    tmp_path: Path,
) -> None:
    path, _ = _checked(tmp_path)
    text = SYSTEM.replace(CONNECTION, '  - p."12"[1] -> q."x  y"')
    published = _published(path, text)
    (unknown,) = [p.lsp for p in published if p.lsp.code == "E021"]
    row, span = text.split("\n")[unknown.range.start.line], unknown.range
    assert row[span.start.character : span.end.character] == 'q."x  y"'
    (action,) = actions(URI, path, text, published, EVERYWHERE)
    fixed = apply(text, _edits(action.edit))
    assert fixed == SYSTEM
    assert _errors(tmp_path, fixed) == []


@pytest.mark.parametrize(
    ("written", "fixed"),
    [
        # E023 (quote `12`) and E021 (did you mean `x y`?)
        ("  - p.12[1] -> q.x_y", CONNECTION),
        # E023 on a name with a blank: the whole name is quoted, not its first word
        ('  - p.a b -> q."x y"', '  - p."a b" -> q."x y"'),
    ],
)
def test_the_fixes_of_an_unquoted_port_quote_it(tmp_path: Path, written: str, fixed: str) -> None:
    path, _ = _checked(tmp_path)
    text = SYSTEM.replace(CONNECTION, written)
    published = _published(path, text)
    assert {p.lsp.code for p in published} & {"E021", "E023"}
    edits: list[types.TextEdit] = []
    for action in actions(URI, path, text, published, EVERYWHERE):
        edits += _edits(action.edit)
    # the fixes of one line, applied together (they do not overlap)
    assert apply(text, edits) == SYSTEM.replace(CONNECTION, fixed)
    assert _errors(tmp_path, apply(text, edits)) == []


def test_the_server_hovers_and_completes_a_quoted_port(server: Session, workspace: Path) -> None:
    folder = workspace / "systems" / "quoted"
    folder.mkdir(exist_ok=True)
    _models(folder)
    path = folder / "system.yaml"
    path.write_text(SYSTEM, encoding="utf-8")
    uri = server.open(path)
    assert [d.code for d in server.wait_diagnostics(uri) if d.severity == 1] == []
    line, column = _position(SYSTEM, "record:", '"12"', 1)
    shown = server.hover(uri, line, column)
    assert shown is not None
    assert isinstance(shown.contents, types.MarkupContent)
    assert shown.contents.value.startswith('**p."12"** — output `float64` [2]')
    text = SYSTEM.replace(CONNECTION, '  - p. -> q."x y"')
    server.change(uri, text)
    line = text.split("\n").index('  - p. -> q."x y"')
    labels = [i.label for i in server.completion(uri, line, len("  - p."))]
    assert sorted(labels) == ['"12"', '"a b"']
