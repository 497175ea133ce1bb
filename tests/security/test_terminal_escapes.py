"""Escape sequences in a model file never reach the terminal: what the CLI quotes from a file
shows its control characters escaped (:func:`fmionnx.core.printable.printable`).

The hostile ONNX model names its input ``x ESC[2J ESC]0;pwned BEL`` (clear the screen, set
the window title) and carries ESC sequences (an OSC 8 hyperlink among them) in its graph name,
doc string, producer and metadata; its output name holds a tab and a line break, which broke
the rows of ``inspect``'s table.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

from onnx import TensorProto, helper
from rich.console import Console
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.cli.inspect_cmd import render_rich
from fmionnx.kinds.onnx.kind import ONNX_KIND

#: Clear the screen, then set the window title.
INPUT = "x\x1b[2J\x1b]0;pwned\x07"
#: A tab and a line break: a table row split in two.
OUTPUT = "y\tz\nw"
#: Control characters no line of output may hold (line breaks end lines; nothing else).
CONTROL = re.compile("[\x00-\x09\x0b-\x1f\x7f-\x9f]")


def _hostile(path: Path, *, shape: list[int] | None = None) -> Path:
    node = helper.make_node("Identity", [INPUT], [OUTPUT])
    graph = helper.make_graph(
        [node],
        "g\x1b[31mred",
        [helper.make_tensor_value_info(INPUT, TensorProto.DOUBLE, shape or [1])],
        [helper.make_tensor_value_info(OUTPUT, TensorProto.DOUBLE, shape or [1])],
    )
    model = helper.make_model(
        graph,
        opset_imports=[helper.make_opsetid("", 17)],
        producer_name="p\x1b[5m\x9b2J",
        doc_string="see \x1b]8;;https://example.invalid\x1b\\here\x1b]8;;\x1b\\",
    )
    model.ir_version = 8
    helper.set_model_props(model, {"author\x1b[1m": "v\x1b[2J\x7f"})
    path.write_bytes(model.SerializeToString())
    return path


def _invoke(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), catch_exceptions=False)
    return result.exit_code, result.output


def test_inspect_shows_the_escape_sequences_of_a_model_escaped(tmp_path: Path) -> None:
    code, output = _invoke("inspect", str(_hostile(tmp_path / "esc.onnx")))
    assert code == 0, output
    assert CONTROL.search(output) is None, repr(output)
    assert "x\\x1b[2J\\x1b]0;pwned\\x07" in output  # the port, as it is named
    assert "g\\x1b[31mred" in output
    assert "p\\x1b[5m\\x9b2J" in output
    assert "\\x1b]8;;https://example.invalid" in output
    assert "author\\x1b[1m" in output
    assert "v\\x1b[2J\\x7f" in output


def test_a_line_break_in_a_port_name_keeps_its_table_row_whole(tmp_path: Path) -> None:
    code, output = _invoke("inspect", str(_hostile(tmp_path / "esc.onnx")))
    assert code == 0, output
    table = output.split("\n\n", 1)[1].splitlines()
    assert [row.split()[0] for row in table] == ["NAME", "x\\x1b[2J\\x1b]0;pwned\\x07", "y\\tz\\nw"]
    assert all(row.split()[2] == "float64" for row in table[1:])


def test_the_terminal_table_of_inspect_shows_them_escaped(tmp_path: Path) -> None:
    """What a terminal gets (rich's table, no colour: every escape left would be the model's)."""
    interface = ONNX_KIND.read_interface(_hostile(tmp_path / "esc.onnx"), None)
    stream = io.StringIO()
    render_rich(interface, Console(file=stream, no_color=True, width=200, highlight=False))
    shown = stream.getvalue()
    assert CONTROL.search(shown) is None, repr(shown)
    assert "pwned\\x07" in shown
    assert "y\\tz\\nw" in shown


def test_an_error_quoting_a_hostile_port_name_shows_it_escaped(tmp_path: Path) -> None:
    huge = _hostile(tmp_path / "huge.onnx", shape=[1000, 1000, 1000, 1000])
    code, output = _invoke("inspect", str(huge))
    assert code == 1
    assert "E008" in output
    assert CONTROL.search(output) is None, repr(output)
    assert "x\\x1b[2J\\x1b]0;pwned\\x07" in output


def test_validate_reports_quote_a_hostile_port_name_escaped(tmp_path: Path) -> None:
    """W030 names the unconnected input, in the text report and in GitHub's annotations."""
    _hostile(tmp_path / "esc.onnx")
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: e\nrun: {stop: 1, step: 0.1}\n"
        "components:\n  m: {kind: onnx, path: esc.onnx}\n",
        encoding="utf-8",
    )
    for report in ("text", "github"):
        code, output = _invoke("validate", str(system), "--format", report)
        assert code == 0, output
        assert "W030" in output
        assert CONTROL.search(output) is None, repr(output)
        assert "`m.x\\x1b[2J\\x1b]0;pwned\\x07`" in output


def test_bidirectional_overrides_are_shown_escaped() -> None:
    """U+202E (right-to-left override) and the isolates reorder the rest of a line: a name
    holding one could make a message read otherwise than it is ("Trojan Source")."""
    from fmionnx.core.printable import printable

    assert printable("ok\u202edaB\u2066x\u2069\u200fy") == "ok\\u202edaB\\u2066x\\u2069\\u200fy"
    assert printable("Größe · 5 °C") == "Größe · 5 °C"  # letters and symbols stay as they are


def test_a_usage_error_quoting_a_file_name_shows_its_escapes_escaped(tmp_path: Path) -> None:
    """`fail()` printed the name of a missing system file as given: ESC and all."""
    name = str(tmp_path / "sys\x1b]0;pwned\x07.yaml")
    code, output = _invoke("run", name)
    assert code != 0
    assert CONTROL.search(output) is None, repr(output)
    assert "sys\\x1b]0;pwned\\x07.yaml" in output
