"""``fmionnx graph`` on the reference system: text formats are golden, images render."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from tests.conftest import REPO

SYSTEM = REPO / "systems" / "sign_follower.yaml"
GOLDEN = Path(__file__).resolve().parent / "golden"


@pytest.mark.parametrize(
    ("fmt", "golden"),
    [
        ("dot", "sign_follower.dot"),
        ("mermaid", "sign_follower.mmd"),
        ("json", "sign_follower.graph.json"),
    ],
)
def test_text_formats_match_their_golden_files(fmt: str, golden: str) -> None:
    result = CliRunner().invoke(
        app, ["graph", str(SYSTEM), "--format", fmt], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    path = GOLDEN / golden
    if os.environ.get("UPDATE_GOLDEN") == "1":
        path.write_text(result.output, encoding="utf-8")
    assert result.output == path.read_text(encoding="utf-8")


def test_json_graph_has_the_papers_shape() -> None:
    result = CliRunner().invoke(app, ["graph", str(SYSTEM), "-f", "json"], catch_exceptions=False)
    graph = json.loads(result.output)
    kinds = {node["name"]: node["kind"] for node in graph["nodes"]}
    assert kinds == {"world": "mujoco", "odometry": "fmu", "detector": "onnx", "tracker": "fmu"}
    pairs = {(edge["source"], edge["target"]) for edge in graph["edges"]}
    assert pairs == {
        ("world", "odometry"),
        ("world", "detector"),
        ("odometry", "tracker"),
        ("detector", "tracker"),
        ("tracker", "world"),
    }
    order = graph["order"]
    # odometry and the detector feed through to their outputs, so the tracker must follow
    # them; the world's sensors and the tracker's commands do not feed through, so those
    # edges are cut and declaration order (world first) breaks the tie.
    assert order == ["world", "odometry", "detector", "tracker"]


@pytest.mark.skipif(
    shutil.which("dot") is None, reason="Graphviz is installed by tools/system-deps.sh"
)
@pytest.mark.parametrize("fmt", ["svg", "png"])
def test_images_are_rendered_with_graphviz(fmt: str, tmp_path: Path) -> None:
    out = tmp_path / f"graph.{fmt}"
    result = CliRunner().invoke(
        app, ["graph", str(SYSTEM), "-f", fmt, "-o", str(out)], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    data = out.read_bytes()
    assert data.startswith(b"\x89PNG") if fmt == "png" else b"<svg" in data and b"tracker" in data


def test_image_format_without_output_is_a_usage_error() -> None:
    result = CliRunner().invoke(app, ["graph", str(SYSTEM), "-f", "svg"])
    assert result.exit_code == 2


def test_a_broken_system_prints_diagnostics_and_exits_1(tmp_path: Path) -> None:
    broken = tmp_path / "broken.yaml"
    broken.write_text(
        "fmionnx: 1\nname: b\ncomponents:\n  a: {kind: fmu, path: missing.fmu}\n", encoding="utf-8"
    )
    result = CliRunner().invoke(app, ["graph", str(broken)], catch_exceptions=False)
    assert result.exit_code == 1
    assert "E010" in result.output


@pytest.mark.parametrize(
    ("name", "golden"),
    [
        ("graph.dot", "sign_follower.dot"),
        ("graph.gv", "sign_follower.dot"),
        ("graph.mmd", "sign_follower.mmd"),
        ("graph.json", "sign_follower.graph.json"),
    ],
)
def test_without_format_the_output_suffix_chooses_it(
    name: str, golden: str, tmp_path: Path
) -> None:
    out = tmp_path / name
    result = CliRunner().invoke(app, ["graph", str(SYSTEM), "-o", str(out)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert out.read_text(encoding="utf-8") == (GOLDEN / golden).read_text(encoding="utf-8")


@pytest.mark.skipif(
    shutil.which("dot") is None, reason="Graphviz is installed by tools/system-deps.sh"
)
def test_an_svg_suffix_writes_svg_not_dot_text(tmp_path: Path) -> None:
    out = tmp_path / "graph.svg"
    result = CliRunner().invoke(app, ["graph", str(SYSTEM), "-o", str(out)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert b"<svg" in out.read_bytes()
    assert not out.read_bytes().startswith(b"digraph")


@pytest.mark.parametrize("name", ["graph.txt", "graph.md", "graph"])
def test_an_unknown_suffix_without_format_is_a_usage_error(name: str, tmp_path: Path) -> None:
    out = tmp_path / name
    result = CliRunner().invoke(app, ["graph", str(SYSTEM), "-o", str(out)])
    assert result.exit_code == 2
    assert "the format cannot be told from it; give `--format`" in " ".join(result.output.split())
    assert not out.exists()


def test_an_explicit_format_wins_over_the_suffix(tmp_path: Path) -> None:
    out = tmp_path / "graph.txt"
    result = CliRunner().invoke(
        app, ["graph", str(SYSTEM), "-f", "mermaid", "-o", str(out)], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    assert out.read_text(encoding="utf-8") == (GOLDEN / "sign_follower.mmd").read_text("utf-8")


def test_mermaid_gives_names_that_differ_only_in_punctuation_their_own_nodes(
    tmp_path: Path,
) -> None:
    """A bug hunt: `a.b`, `a_b` and `a-b` became one node `n_a_b`, drawn feeding three
    gains (SSP's nested names hold dots, so this comes up)."""
    system = tmp_path / "col.yaml"
    sources = "".join(
        f"  {n}: {{kind: signal, outputs: {{s: {{constant: 1}}}}}}\n" for n in ("a.b", "a_b", "a-b")
    )
    system.write_text(
        "fmionnx: 1\nname: col\nrun: {stop: 1, step: 0.1}\ncomponents:\n" + sources
        + "connections: []\n",
        encoding="utf-8",
    )  # fmt: skip
    result = CliRunner().invoke(app, ["graph", str(system), "-f", "mermaid"])
    assert result.exit_code == 0, result.output
    nodes = [line.split("(")[0].split("[")[0].strip() for line in result.output.splitlines()[1:4]]
    assert nodes == ["n_a_b", "n_a_b_2", "n_a_b_3"]
    assert "class n_a_b,n_a_b_2,n_a_b_3 signal" in result.output
