"""A plot's ``file`` stays inside the output folder: refused at compile time, ignored at write."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import fmionnx
from fmionnx import api
from fmionnx.compile.ir import plot_file_problem
from fmionnx.compile.plotfiles import slug, unique_name
from fmionnx.results import write_results
from tests.conftest import build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: plotted
run: {{stop: 0.1, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}, parameters: {{u: 1.0, v: [0, 0, 0]}}}}
record: [gain.y]
plots:
  - {{y: [gain.y], file: {file}}}
"""


def _system(folder: Path, file: str) -> Path:
    path = folder / "plotted.yaml"
    path.write_text(SYSTEM.format(gain=build_fixture_fmu("Gain"), file=file), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    "file", ["../escape.png", "/abs/escape.png", "sub/escape.png", ".hidden.png", "'..'"]
)
def test_a_plot_file_outside_the_output_folder_is_an_error_at_its_place(
    tmp_path: Path, file: str
) -> None:
    result = api.compile_system(_system(tmp_path, file))
    errors = [d for d in result.diagnostics if d.code == "E045"]
    assert len(errors) == 1, [str(d) for d in result.diagnostics]
    assert errors[0].span is not None
    assert (errors[0].span.line, errors[0].span.col) == (8, 25)
    assert "plain file name" in errors[0].message
    assert result.system is None


def test_a_plain_plot_file_name_is_written_inside_the_output_folder(tmp_path: Path) -> None:
    system = fmionnx.load(_system(tmp_path, "gain.png"))
    out = tmp_path / "out"
    out.mkdir()
    written = write_results(system.run(isolate="none"), system.compiled, out)
    assert out / "gain.png" in written


def test_a_hand_edited_compiled_system_cannot_write_a_plot_outside(tmp_path: Path) -> None:
    system = fmionnx.load(_system(tmp_path, "gain.png"))
    plot = dataclasses.replace(system.compiled.plots[0], file="../escape.png")
    compiled = dataclasses.replace(system.compiled, plots=(plot,))
    out = tmp_path / "out"
    out.mkdir()
    written = write_results(system.run(isolate="none"), compiled, out)
    assert not (tmp_path / "escape.png").exists()
    pngs = [p for p in written if p.suffix == ".png"]
    assert [p.parent for p in pngs] == [out]


@pytest.mark.parametrize(
    ("title", "name"),
    [
        ("Trajectory A -> B", "trajectory-a-b"),
        ("  Velocity  commands (v, w)  ", "velocity-commands-v-w"),
        ("Étape ../../etc/passwd", "tape-etc-passwd"),
        ("->", "plot"),
        ("x" * 100, "x" * 60),
    ],
)
def test_a_title_becomes_a_plain_file_stem(title: str, name: str) -> None:
    assert slug(title) == name
    assert plot_file_problem(name + ".png") is None


def test_derived_names_are_unique_and_never_the_signals_figure() -> None:
    taken: set[str] = {"trajectory.png"}
    assert [unique_name(s, taken) for s in ("trajectory", "trajectory", "signals")] == [
        "trajectory-2.png",
        "trajectory-3.png",
        "signals-2.png",
    ]


def test_a_hand_edited_compiled_system_with_one_file_twice_writes_two(tmp_path: Path) -> None:
    system = fmionnx.load(_system(tmp_path, "gain.png"))
    plot = system.compiled.plots[0]
    compiled = dataclasses.replace(system.compiled, plots=(plot, plot))
    out = tmp_path / "out"
    out.mkdir()
    written = write_results(system.run(isolate="none"), compiled, out)
    assert sorted(p.name for p in written if p.suffix == ".png") == ["gain-2.png", "gain.png"]
