"""Plots are resolved at compile time: columns, units, the path and map underneath, file names.

The results writer reads only the compiled system, so what it needs must be there, and must
come back unchanged from the compiled-system file.
"""

from __future__ import annotations

from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper

from fmionnx import api
from fmionnx.compile.expected_path import read_expected_path
from fmionnx.compile.ir import CompiledSystem, Plot, Series
from fmionnx.compile.systemfile import from_json, to_json
from fmionnx.core.diagnostics import Diagnostic
from tests.conftest import REPO, build_fixture_fmu

REFERENCE = REPO / "systems" / "sign_follower.yaml"
SCENE = REPO / "models" / "world" / "sign_course.xml"


@pytest.fixture(scope="module")
def reference() -> CompiledSystem:
    result = api.compile_system(REFERENCE)
    assert result.system is not None, [str(d) for d in result.diagnostics]
    return result.system


def test_the_trajectory_carries_units_path_and_map(reference: CompiledSystem) -> None:
    trajectory = reference.plots[0]
    assert trajectory.series == (
        Series("odometry.posX", ("odometry.posX",), "m"),
        Series("odometry.posY", ("odometry.posY",), "m"),
    )
    assert [s.label for s in trajectory.series] == ["odometry.posX [m]", "odometry.posY [m]"]
    assert trajectory.path == read_expected_path(SCENE.with_name("sign_course.path.csv"))
    assert trajectory.scene is not None
    assert {s.name for s in trajectory.scene.sites} == {"A", "B"}
    boards = {s.name for s in trajectory.scene.shapes if s.name.endswith("_board")}
    assert boards == {"sign_left_board", "sign_right_board", "sign_stop_board"}


def test_file_names_come_from_the_titles(reference: CompiledSystem) -> None:
    assert [p.file for p in reference.plots] == ["trajectory-a-b.png", "velocity-commands.png"]
    assert reference.plots[1].series == (
        Series("tracker.v", ("tracker.v",), "m/s"),
        Series("tracker.w", ("tracker.w",), "rad/s"),
    )


def test_resolved_plots_survive_the_compiled_system_file(reference: CompiledSystem) -> None:
    back = from_json(to_json(reference))
    assert back.plots == reference.plots
    assert back.plots[0].scene == reference.plots[0].scene
    assert isinstance(back.plots[0].scene.shapes[0].outline[0], tuple)  # type: ignore[union-attr]


# -- plots of small systems ----------------------------------------------------------------

SYSTEM = """\
fmionnx: 1
name: plotted
run: {{stop: 0.1, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}, parameters: {{u: 1.0, v: [0, 0, 0]}}}}
  world: {{kind: mujoco, path: {scene}}}
record: [gain.y]
plots:
{plots}
"""


def _compile(
    tmp_path: Path, plots: str, scene: Path = SCENE
) -> tuple[CompiledSystem | None, list[Diagnostic]]:
    path = tmp_path / "plotted.yaml"
    text = SYSTEM.format(gain=build_fixture_fmu("Gain"), scene=scene, plots=plots)
    path.write_text(text, encoding="utf-8")
    result = api.compile_system(path)
    return result.system, [d for d in result.diagnostics if d.code.startswith("E")]


def _plots(tmp_path: Path, plots: str) -> tuple[Plot, ...]:
    system, errors = _compile(tmp_path, plots)
    assert system is not None, [str(d) for d in errors]
    return system.plots


def test_an_array_port_is_a_line_per_element_and_an_element_one_signal(tmp_path: Path) -> None:
    (plot,) = _plots(tmp_path, "  - {y: [gain.w, 'gain.v[1]']}")
    assert plot.series == (
        Series("gain.w", ("gain.w[0]", "gain.w[1]", "gain.w[2]"), "m"),
        Series("gain.v[1]", ("gain.v[1]",), "m"),
    )
    assert plot.file == "gain-w-gain-v-1.png"


def test_untitled_plots_are_named_by_what_they_draw_and_never_twice(tmp_path: Path) -> None:
    plots = _plots(
        tmp_path,
        "  - {xy: [gain.y, gain.u], over: world.expected_path}\n"
        "  - {xy: [gain.y, gain.u]}\n"
        "  - {y: [gain.y], title: Trajectory}\n"
        "  - {y: [gain.y], title: Trajectory}\n"
        "  - {y: [gain.y], title: Signals}\n"
        "  - {y: [gain.y], file: mine}",
    )
    assert [p.file for p in plots] == [
        "trajectory.png",
        "gain-u-vs-gain-y.png",
        "trajectory-2.png",
        "trajectory-3.png",
        "signals-2.png",  # signals.png is what `run --plot` writes
        "mine.png",
    ]


def test_over_the_map_alone_draws_no_path(tmp_path: Path) -> None:
    (plot,) = _plots(tmp_path, "  - {xy: [gain.y, gain.u], over: world.map}")
    assert plot.path == ()
    assert plot.scene is not None
    assert [s.name for s in plot.scene.sites] == ["A", "B"]


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ("{xy: [gain.y, gain.u], over: gain.map}", "component `gain` (fmu) has no map"),
        (
            "{xy: [gain.y, gain.u], over: world.path}",
            "`path` is neither the expected path nor the map",
        ),
        ("{y: [gain.y], over: world.map}", "`over` draws under an xy plot"),
        (
            "{y: [gain.y], file: same.png}\n  - {y: [gain.u], file: same}",
            "written by an earlier plot",
        ),
    ],
)
def test_a_reference_or_file_that_cannot_be_drawn_is_e045(
    tmp_path: Path, entry: str, message: str
) -> None:
    system, errors = _compile(tmp_path, f"  - {entry}")
    assert system is None
    assert [d.code for d in errors] == ["E045"], [str(d) for d in errors]
    assert message in errors[0].message
    assert errors[0].span is not None
    assert errors[0].span.line >= 9


def test_a_scene_without_an_expected_path_is_e045_at_over(tmp_path: Path) -> None:
    scene = tmp_path / "bare.xml"
    scene.write_text("<mujoco><worldbody><site name='A'/></worldbody></mujoco>", encoding="utf-8")
    system, errors = _compile(
        tmp_path, "  - {xy: [gain.y, gain.u], over: world.expected_path}", scene
    )
    assert system is None
    assert [d.code for d in errors] == ["E045"]
    assert "`bare.path.csv` is not next to `bare.xml`" in errors[0].message
    assert (errors[0].span.line, errors[0].span.col) == (9, 34)  # type: ignore[union-attr]


@pytest.mark.parametrize(
    ("signal", "why"),
    [
        ("gain.k", "is a parameter"),
        ("gain.w", "an xy axis is one signal; `gain.w` has 3 elements"),
    ],
)
def test_a_signal_an_xy_axis_cannot_draw_is_e046_at_its_place(
    tmp_path: Path, signal: str, why: str
) -> None:
    system, errors = _compile(tmp_path, f"  - {{xy: [gain.y, {signal}]}}")
    assert system is None
    assert [d.code for d in errors] == ["E046"]
    assert why in errors[0].message
    assert (errors[0].span.line, errors[0].span.col) == (9, 19)  # type: ignore[union-attr]


def _wide_model(path: Path) -> Path:
    """An ONNX model with a ``[1,100]`` input and an input of symbolic size ``[N]``."""
    graph = helper.make_graph(
        [
            helper.make_node("Identity", ["wide"], ["wide_out"]),
            helper.make_node("Identity", ["free"], ["free_out"]),
        ],
        "wide",
        [
            helper.make_tensor_value_info("wide", TensorProto.FLOAT, [1, 100]),
            helper.make_tensor_value_info("free", TensorProto.FLOAT, ["N"]),
        ],
        [
            helper.make_tensor_value_info("wide_out", TensorProto.FLOAT, [1, 100]),
            helper.make_tensor_value_info("free_out", TensorProto.FLOAT, ["N"]),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


@pytest.mark.parametrize(
    ("signal", "why"),
    [
        ("net.wide_out", "`net.wide_out` has 100 elements; a time plot draws at most 64 lines"),
        ("net.free_out", "`net.free_out` has a size known only at run time ([N])"),
    ],
)
def test_a_signal_a_time_plot_cannot_draw_is_e046(tmp_path: Path, signal: str, why: str) -> None:
    model = _wide_model(tmp_path / "wide.onnx")
    path = tmp_path / "wide.yaml"
    path.write_text(
        "fmionnx: 1\nname: wide\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
        f"  net: {{kind: onnx, path: {model}}}\nplots:\n  - {{y: ['net.wide_out[0,3]', {signal}]}}\n",
        encoding="utf-8",
    )
    result = api.compile_system(path)
    errors = [d for d in result.diagnostics if d.code.startswith("E")]
    assert [d.code for d in errors] == ["E046"], [str(d) for d in errors]
    assert why in errors[0].message
    assert (errors[0].span.line, errors[0].span.col) == (7, 31)  # type: ignore[union-attr]


def test_the_scene_labels_its_boards_for_the_legend(reference: CompiledSystem) -> None:
    trajectory = reference.plots[0]
    assert trajectory.scene is not None
    labels = {s.name: s.label for s in trajectory.scene.shapes if s.label}
    assert labels == {
        "sign_left_board": "blue board: turn left",
        "sign_right_board": "green board: turn right",
        "sign_stop_board": "red board: stop",
    }
    assert from_json(to_json(reference)) == reference  # labels and marks travel


def _marks_errors(tmp_path: Path, plot: str) -> list[str]:
    gain = build_fixture_fmu("Gain")
    path = tmp_path / "marks.yaml"
    path.write_text(
        "fmionnx: 1\nname: marks\nrun: {stop: 1, step: 0.1}\n"
        f"components:\n  g: {{kind: fmu, path: {gain}}}\nplots:\n  - {plot}\n",
        encoding="utf-8",
    )
    result = api.compile_system(path)
    return [f"{d.code} {d.message}" for d in result.diagnostics if d.code.startswith("E")]


@pytest.mark.parametrize(
    ("plot", "expected"),
    [
        (
            "{xy: [g.y, g.u], marks: {of: g.y}}",
            "E045 `marks` are drawn on a plot over time; this is an xy plot",
        ),
        (
            "{y: [g.y], marks: {of: g.w}}",
            "E046 plot marks: follow one signal; `g.w` has 3 elements",
        ),
        (
            "{y: [g.y], marks: {of: g.z}}",
            "E045 plot marks: component `g` (fmu) has no port `z`",
        ),
        (
            "{y: [g.y], marks: {of: g.k}}",
            "E046 plot: `g.k` is a parameter: it does not change during a run and is not recorded",
        ),
    ],
)
def test_marks_that_cannot_be_drawn_are_refused(tmp_path: Path, plot: str, expected: str) -> None:
    assert _marks_errors(tmp_path, plot) == [expected]
