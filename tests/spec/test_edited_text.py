"""While a file is being edited (``core.sourcetext.editing``), every reader of that file sees
the editor's text: the YAML reader, the SSD parser and the column fix-ups; the file on disk is
neither read nor written, and outside the block it is read as before."""

from __future__ import annotations

from pathlib import Path

from fmionnx import api
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.sourcetext import editing, source_lines
from fmionnx.spec.limits import MAX_DOCUMENT_BYTES
from fmionnx.spec.ssp_xml import parse_xml
from fmionnx.spec.yaml import read_text

SIGNALS = """\
fmionnx: 1
name: edited
run: {stop: 1, step: 0.1}
components:
  src: {kind: signal, outputs: {a: {constant: 1}}}
  dst: {kind: signal, outputs: {b: {constant: 2}}}
record: [src.a, dst.b]
"""


def test_the_compiler_checks_the_edited_text_and_leaves_the_file_alone(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(SIGNALS, encoding="utf-8")
    # a name inside a check expression: its column is found again in the source's lines
    edited = SIGNALS + 'checks:\n  - expect: "final(dst.bb) > 1"\n'
    with editing({path: edited}):
        found = api.compile_system(path).diagnostics
    errors = [(d.code, d.span.line, d.span.col) for d in found if d.code[0] == "E" and d.span]
    assert errors == [("E091", 9, 20)]  # `dst.bb`, not the start of the value (column 13)
    assert path.read_text(encoding="utf-8") == SIGNALS
    assert api.compile_system(path).ok  # outside the block: the file, which has no check


def test_an_edited_file_is_found_by_any_name_of_it(tmp_path: Path, monkeypatch) -> None:
    path = tmp_path / "system.yaml"
    path.write_text("old\n", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    with editing({path: "new\nlines\n"}):
        assert read_text(Path("system.yaml"), DiagnosticBag()) == "new\nlines\n"
        assert source_lines(Path("./system.yaml")) == ("new", "lines")
    assert source_lines(Path("system.yaml")) == ("old",)


def test_an_edited_text_over_the_size_limit_is_refused_like_a_file(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    bag = DiagnosticBag()
    with editing({path: "#" * (MAX_DOCUMENT_BYTES + 1)}):
        assert read_text(path, bag) is None
    assert [d.code for d in bag] == ["E003"]


def test_an_edited_ssd_is_parsed_from_its_text(tmp_path: Path) -> None:
    path = tmp_path / "SystemStructure.ssd"
    path.write_text("<not-xml", encoding="utf-8")
    with editing({path: '<?xml version="1.0" encoding="UTF-8"?>\n<a>\n  <b name="x"/>\n</a>\n'}):
        tree = parse_xml(path, DiagnosticBag())
    assert tree is not None
    [element] = tree.getroot()
    assert (element.get("name"), element.sourceline) == ("x", 3)
    bag = DiagnosticBag()
    assert parse_xml(path, bag) is None  # the file itself is not well-formed
    assert [d.code for d in bag] == ["E001"]
