"""``fmionnx graph`` quotes every text it puts into a graph for the format it lands in.

A model file named ``R&D.fmu`` made Graphviz refuse the whole graph ("not well-formed"): the
name went raw into DOT's HTML-like label. Port names (an ONNX model's can hold anything) go
into edge labels, and Mermaid reads ``"``, ``#``, ``<`` and a backtick in its labels.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.compile.ir import CompiledSystem
from fmionnx.export.graph import to_dot, to_mermaid
from fmionnx.pipeline.system import compile_system
from tests.conftest import REPO, build_fixture_fmu

#: Names with every character DOT's HTML-like labels read as markup, and an escape sequence.
FILES = ("R&D.fmu", "<b>.fmu", "e\x1b[2J.fmu")
#: A port name Mermaid and DOT would read as syntax: quote, entity, tag, Markdown, line break.
PORT = 'y"<b>&#quot;`\\l\x1b[2J\n'


def _system(folder: Path) -> Path:
    gain = build_fixture_fmu("Gain")
    lines = ["fmionnx: 1", "name: amp", "run: {stop: 1, step: 0.1}", "components:"]
    for number, name in enumerate(FILES):
        shutil.copyfile(gain, folder / name)
        quoted = json.dumps(name)  # a YAML double-quoted string: `\u001b` for the escape
        lines.append(f"  g{number}: {{kind: fmu, path: {quoted}}}")
    system = folder / "amp.yaml"
    system.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return system


def _graph(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, ["graph", *args], catch_exceptions=False)
    return result.exit_code, result.output


def test_file_names_are_escaped_in_the_dot_label(tmp_path: Path) -> None:
    code, dot = _graph(str(_system(tmp_path)))
    assert code == 0, dot
    assert "R&amp;D.fmu" in dot
    assert "&lt;b&gt;.fmu" in dot
    assert "e\\x1b[2J.fmu" in dot  # shown escaped (a backslash is plain text in an HTML-like label)
    assert "\x1b" not in dot
    assert "R&D" not in dot


@pytest.mark.skipif(
    shutil.which("dot") is None, reason="Graphviz is installed by tools/system-deps.sh"
)
def test_graphviz_renders_a_system_of_awkwardly_named_files(tmp_path: Path) -> None:
    out = tmp_path / "amp.svg"
    code, output = _graph(str(_system(tmp_path)), "-o", str(out))
    assert code == 0, output
    svg = out.read_text(encoding="utf-8")
    assert "R&amp;D.fmu" in svg
    assert "&lt;b&gt;.fmu" in svg


def test_the_json_graph_keeps_the_file_names_as_they_are(tmp_path: Path) -> None:
    code, text = _graph(str(_system(tmp_path)), "-f", "json")
    assert code == 0, text
    assert {node["model"] for node in json.loads(text)["nodes"]} == set(FILES)


def _with_hostile_port() -> CompiledSystem:
    """The reference system with one connection's source port renamed to :data:`PORT`."""
    compiled = compile_system(REPO / "systems" / "sign_follower.yaml").system
    assert compiled is not None
    first, *rest = compiled.connections
    renamed = dataclasses.replace(first, src=dataclasses.replace(first.src, port=PORT))
    return dataclasses.replace(compiled, connections=(renamed, *rest))


def test_a_port_name_stays_text_in_a_dot_edge_label() -> None:
    dot = to_dot(_with_hostile_port())
    (line,) = [line for line in dot.splitlines() if 'y\\"' in line]
    assert 'y\\"<b>&#quot;`\\\\l\\\\x1b[2J\\\\n' in line
    assert "\x1b" not in dot
    if shutil.which("dot") is not None:
        rendered = subprocess.run(
            ["dot", "-Tsvg"], input=dot.encode(), capture_output=True, check=False
        )
        assert rendered.returncode == 0, rendered.stderr


def test_a_port_name_stays_text_in_a_mermaid_edge_label() -> None:
    mermaid = to_mermaid(_with_hostile_port())
    (line,) = [line for line in mermaid.splitlines() if "y#34;" in line]
    assert "y#34;#60;b#62;#38;#35;quot;#96;\\l\\x1b[2J\\n" in line
    assert "\x1b" not in mermaid
    assert line.count('"') == 2  # the label's own quotes, nothing else


def test_an_output_file_in_a_folder_that_takes_no_file_is_a_usage_error(tmp_path: Path) -> None:
    """``/proc/version`` exists (root may write it), but the writer makes a new file beside it
    and renames it over: ``/proc`` takes none. That failed after the compile, exit 1, saying
    "cannot write it (No such file or directory)" of a file that is there."""
    code, output = _graph(str(_system(tmp_path)), "-o", "/proc/version", "-f", "dot")
    assert code == 2, output
    assert "--output `/proc/version`" in output
    assert "cannot write it" not in output
