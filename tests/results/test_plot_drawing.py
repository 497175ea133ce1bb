"""What the plots show, read from the figure's artists before it is saved (not from pixels).

The reference system is compiled for real (its scene map and expected path come through the
kind); the recorded signals are made up where a run would add nothing but time.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import onnx
import pytest
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from onnx import TensorProto, helper

import fmionnx
from fmionnx import api
from fmionnx.compile.ir import CompiledSystem
from fmionnx.results import write_results
from fmionnx.results.csvfile import read_csv
from fmionnx.results.plots import draw_plot, write_plots
from fmionnx.results.signals_plot import draw_signals, signal_series
from fmionnx.runtime.result import RunResult, RunStatus
from tests.conftest import REPO

REFERENCE = REPO / "systems" / "sign_follower.yaml"


@pytest.fixture(scope="module")
def reference() -> CompiledSystem:
    result = api.compile_system(REFERENCE)
    assert result.system is not None
    return result.system


def _result(signals: dict[str, np.ndarray], steps: int = 4) -> RunResult:
    return RunResult(
        system="sign_follower",
        backend="inprocess",
        status=RunStatus.COMPLETED,
        start=0.0,
        stop=steps * 0.5,
        step=0.5,
        steps_done=steps,
        wall_time=0.01,
        time=np.arange(steps + 1) * 0.5,
        signals=signals,
    )


def _driven(reference: CompiledSystem) -> RunResult:
    """The robot driving the expected path exactly, with its commands."""
    path = np.array(reference.plots[0].path)
    return _result(
        {
            "odometry.posX": path[:, 0],
            "odometry.posY": path[:, 1],
            "tracker.v": np.array([0.4, 0.4, 0.0, 0.4]),
            "tracker.w": np.array([0.0, 0.8, 0.0, 0.0]),
            "tracker.state": np.array([1.0, 2.0, 2.0, 4.0]),
        },
        steps=len(path) - 1,
    )


def _drawn(plot_index: int, reference: CompiledSystem, result: RunResult) -> Figure:
    figure = Figure()
    draw_plot(figure, reference.plots[plot_index], result)
    return figure


def test_the_trajectory_is_drawn_over_the_map_with_a_and_b_named(reference: CompiledSystem) -> None:
    (axes,) = _drawn(0, reference, _driven(reference)).axes
    texts = {t.get_text(): t.xy for t in axes.texts if t.get_gid() != "time marks"}
    assert texts == {"A": (0.0, 0.0), "B": (6.0, 3.0)}
    boards = {p.get_gid(): p for p in axes.patches if str(p.get_gid()).endswith("_board")}
    colours = {gid: tuple(round(c, 2) for c in p.get_facecolor()) for gid, p in boards.items()}
    assert colours == {
        "sign_left_board": (0.05, 0.05, 0.85, 1.0),  # blue: turn left
        "sign_right_board": (0.05, 0.75, 0.05, 1.0),  # green: turn right
        "sign_stop_board": (0.85, 0.05, 0.05, 1.0),  # red: stop
    }
    stop = boards["sign_stop_board"].get_xy()
    assert (stop[:, 0].min(), stop[:, 0].max()) == pytest.approx((7.78, 7.82))
    lines = {line.get_label(): line for line in axes.lines}
    assert {"expected path", "simulated", "start", "end"} <= set(lines)
    np.testing.assert_array_equal(lines["expected path"].get_xydata(), reference.plots[0].path)


def test_the_trajectory_axes_carry_the_signals_units(reference: CompiledSystem) -> None:
    (axes,) = _drawn(0, reference, _driven(reference)).axes
    assert (axes.get_xlabel(), axes.get_ylabel()) == ("odometry.posX [m]", "odometry.posY [m]")
    assert axes.get_title() == "Trajectory A -> B"


def test_a_time_plot_has_a_panel_and_a_y_label_per_unit(reference: CompiledSystem) -> None:
    figure = _drawn(1, reference, _driven(reference))
    assert [a.get_ylabel() for a in figure.axes] == ["tracker.v [m/s]", "tracker.w [rad/s]"]
    assert figure.axes[-1].get_xlabel() == "time [s]"
    plotted = [[line for line in a.lines if line.get_gid() != "marks"] for a in figure.axes]
    assert [len(lines) for lines in plotted] == [1, 1]
    np.testing.assert_array_equal(plotted[1][0].get_ydata(), [0.0, 0.8, 0.0, 0.0])


def test_a_signal_missing_from_the_run_is_named_on_the_figure(
    reference: CompiledSystem, caplog: pytest.LogCaptureFixture
) -> None:
    result = _driven(reference)
    del result.signals["tracker.w"]
    figure = _drawn(1, reference, result)
    notes = [t.get_text() for a in figure.axes for t in a.texts if t.get_gid() == "not recorded"]
    assert notes == ["not recorded in this run: `tracker.w`"]
    assert "`tracker.w` not recorded" in caplog.text


def test_written_plot_files_are_named_from_their_titles(
    reference: CompiledSystem, tmp_path: Path
) -> None:
    written = write_plots(_driven(reference), reference, tmp_path)
    assert [p.name for p in written] == ["trajectory-a-b.png", "velocity-commands.png"]
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in written)


def test_the_signals_figure_has_a_panel_per_port_with_its_unit(reference: CompiledSystem) -> None:
    result = _driven(reference)
    result.signals["detector.blobX[0,0]"] = np.zeros(len(result.time))
    result.signals["detector.blobX[0,1]"] = np.ones(len(result.time))
    series = signal_series(result, reference)
    assert [(s.signal, s.columns, s.unit) for s in series] == [
        ("odometry.posX", ("odometry.posX",), "m"),
        ("odometry.posY", ("odometry.posY",), "m"),
        ("tracker.v", ("tracker.v",), "m/s"),
        ("tracker.w", ("tracker.w",), "rad/s"),
        ("tracker.state", ("tracker.state",), None),
        ("detector.blobX", ("detector.blobX[0,0]", "detector.blobX[0,1]"), None),
    ]
    figure = draw_signals(series, result, title="t")
    assert [a.get_ylabel() for a in figure.axes] == [
        "odometry.posX [m]",
        "odometry.posY [m]",
        "tracker.v [m/s]",
        "tracker.w [rad/s]",
        "tracker.state",
        "detector.blobX",
    ]
    assert [line.get_label() for line in figure.axes[-1].lines] == [
        "detector.blobX[0,0]",
        "detector.blobX[0,1]",
    ]


def test_plot_signals_writes_signals_png_and_lists_it_until_a_run_without(
    reference: CompiledSystem, tmp_path: Path
) -> None:
    result = _driven(reference)
    write_results(result, reference, tmp_path, plot_signals=True)
    files = json.loads((tmp_path / "run.json").read_text(encoding="utf-8"))["files"]
    assert "signals.png" in files
    assert (tmp_path / "signals.png").read_bytes().startswith(b"\x89PNG")
    write_results(result, reference, tmp_path)  # a later run without --plot
    assert not (tmp_path / "signals.png").exists()


def test_a_run_that_recorded_nothing_draws_no_plots_and_says_so_once(
    reference: CompiledSystem, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    write_results(_driven(reference), reference, tmp_path, plot_signals=True)
    assert (tmp_path / "trajectory-a-b.png").exists()
    stopped = _result({}, steps=0)  # stopped before its models gave a first value
    write_results(stopped, reference, tmp_path, plot_signals=True)
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".")) == [
        "results.csv",
        "run.json",
    ]  # the previous run's figures are gone with it, none drawn empty
    assert json.loads((tmp_path / "run.json").read_text(encoding="utf-8"))["files"] == [
        "results.csv",
        "run.json",
    ]
    # no row: the start time alone was one that said nothing
    assert (tmp_path / "results.csv").read_text(encoding="utf-8") == "time\n"
    assert list(read_csv(tmp_path / "results.csv")) == ["time"]
    assert len(read_csv(tmp_path / "results.csv")["time"]) == 0
    warned = [r.getMessage() for r in caplog.records if r.name == "fmionnx.results"]
    assert warned == [
        "plots: none drawn: the run stopped before its models gave a first value, so "
        "nothing was recorded"
    ]


def _one_element_model(path: Path) -> Path:
    """``y = 2 x`` on ``[1]``-shaped float tensors, and ``z = x`` as ``[1,3]``."""
    graph = helper.make_graph(
        [
            helper.make_node("Add", ["x", "x"], ["y"]),
            helper.make_node("Expand", ["x", "shape"], ["z"]),
        ],
        "one",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1])],
        [
            helper.make_tensor_value_info("y", TensorProto.FLOAT, [1]),
            helper.make_tensor_value_info("z", TensorProto.FLOAT, [1, 3]),
        ],
        initializer=[helper.make_tensor("shape", TensorProto.INT64, [2], [1, 3])],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


def test_a_one_element_onnx_port_is_plotted_as_one_signal_of_a_real_run(tmp_path: Path) -> None:
    model = _one_element_model(tmp_path / "one.onnx")
    system_file = tmp_path / "one.yaml"
    system_file.write_text(
        "fmionnx: 1\nname: one\nrun: {stop: 0.3, step: 0.1}\ncomponents:\n"
        f"  net: {{kind: onnx, path: {model}, parameters: {{x: [1.5]}}}}\n"
        "plots:\n  - {y: [net.y, net.z], title: One and three}\n",
        encoding="utf-8",
    )
    system = fmionnx.load(system_file)
    result = system.run(isolate="none")
    figure = Figure()
    draw_plot(figure, system.compiled.plots[0], result)
    (axes,) = figure.axes
    assert axes.get_ylabel() == "net.y, net.z"
    assert [line.get_label() for line in axes.lines] == [
        "net.y",
        "net.z[0,0]",
        "net.z[0,1]",
        "net.z[0,2]",
    ]
    np.testing.assert_array_equal(axes.lines[0].get_ydata(), [3, 3, 3, 3])
    np.testing.assert_array_equal(axes.lines[3].get_ydata(), [1.5, 1.5, 1.5, 1.5])
    assert to_rgba(axes.lines[0].get_color()) != to_rgba(axes.lines[1].get_color())


def test_the_trajectory_legend_says_what_the_boards_mean(reference: CompiledSystem) -> None:
    """The scene labels its boards (``label:<geom>`` custom texts): the legend names each in
    its colour (issue #34: the colours' meaning was nowhere on the plot)."""
    (axes,) = _drawn(0, reference, _driven(reference)).axes
    handles, labels = axes.get_legend_handles_labels()
    meaning = {
        label: tuple(round(c, 2) for c in handle.get_facecolor())
        for handle, label in zip(handles, labels, strict=True)
        if label.endswith(("left", "right", "stop"))
    }
    assert meaning == {
        "blue board: turn left": (0.05, 0.05, 0.85, 1.0),
        "green board: turn right": (0.05, 0.75, 0.05, 1.0),
        "red board: stop": (0.85, 0.05, 0.05, 1.0),
    }


def test_the_trajectory_marks_the_time_along_the_run(reference: CompiledSystem) -> None:
    steps = 40
    t = np.arange(steps + 1) * 0.5  # 20 s: a mark every 5 s (at most 8 marks)
    result = _result({"odometry.posX": t / 10, "odometry.posY": np.zeros_like(t)}, steps=steps)
    (axes,) = _drawn(0, reference, result).axes
    (dots,) = [line for line in axes.lines if line.get_gid() == "time marks"]
    np.testing.assert_allclose(dots.get_xdata(), [0.5, 1.0, 1.5])  # x = t / 10 at 5, 10, 15 s
    assert dots.get_label() == "every 5 s"
    labels = [text.get_text() for text in axes.texts if text.get_gid() == "time marks"]
    assert labels == ["5 s", "10 s", "15 s"]


@pytest.mark.parametrize(
    ("duration", "step"), [(32.0, 5.0), (20.0, 5.0), (8.0, 1.0), (1800.0, 500.0), (0.3, 0.05)]
)
def test_time_marks_fall_on_round_seconds(duration: float, step: float) -> None:
    from fmionnx.results.plots import MOST_TIME_MARKS, time_step

    assert time_step(duration) == pytest.approx(step)
    assert duration / time_step(duration) <= MOST_TIME_MARKS


def test_the_velocity_plot_marks_the_trackers_state_changes(reference: CompiledSystem) -> None:
    """``marks: {of: tracker.state, labels: ...}``: a line on every panel where the state
    changes, its new value named on the top one (issue #34)."""
    figure = _drawn(1, reference, _driven(reference))
    for axes in figure.axes:
        marks = [line.get_xdata()[0] for line in axes.lines if line.get_gid() == "marks"]
        assert marks == [0.5, 1.5]  # 1 -> 2 at t = 0.5, 2 -> 4 at t = 1.5
    top = [t.get_text() for t in figure.axes[0].texts if t.get_gid() == "marks"]
    assert top == ["turn left", "stop"]
    assert not [t for t in figure.axes[1].texts if t.get_gid() == "marks"]


def test_marks_are_resolved_and_recorded(reference: CompiledSystem) -> None:
    marks = reference.plots[1].marks
    assert marks is not None
    assert (marks.signal, marks.column) == ("tracker.state", "tracker.state")
    assert marks.label(2.0) == "turn left"
    assert marks.label(7.0) == "tracker.state = 7"
    assert "tracker.state" in [str(ref) for ref in reference.plots[1].refs]


def test_a_figure_is_laid_out_once_and_drawn_once_when_saved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``tight_layout`` leaves a placeholder layout engine behind, and with an engine set
    ``savefig`` lays the whole figure out again before drawing it (a third of a figure's
    time): the engine is taken off once the layout is done, and the file is the same."""
    from fmionnx.results.plots import save_figure

    def figure() -> Figure:
        drawn = Figure(figsize=(4, 3), dpi=50)
        axes = drawn.subplots()
        image = axes.imshow([[0.0, 1.0], [2.0, 3.0]])
        drawn.colorbar(image, ax=axes, label="value [m]")
        axes.set_xlabel("a long label on the x axis")
        return drawn

    draws: list[int] = []
    original = Figure.draw

    def counting(self: Figure, renderer: object) -> None:
        draws.append(1)
        original(self, renderer)

    monkeypatch.setattr(Figure, "draw", counting)
    save_figure(figure(), tmp_path / "once.png")
    assert len(draws) == 1
    laid_out_again = figure()
    laid_out_again.tight_layout()
    laid_out_again.savefig(tmp_path / "again.png")  # as before: tight_layout, then savefig
    assert len(draws) == 3
    assert (tmp_path / "once.png").read_bytes() == (tmp_path / "again.png").read_bytes()


@pytest.mark.parametrize("setting", ["figure.constrained_layout.use", "figure.autolayout"])
def test_a_users_matplotlib_layout_setting_changes_no_figure(tmp_path: Path, setting: str) -> None:
    """A ``matplotlibrc`` that turns constrained layout on made ``tight_layout`` refuse a
    figure holding a colour bar (a study's heat map): the plot was not drawn. The figures
    are made without a layout engine whatever the settings, and come out the same."""
    import matplotlib

    from fmionnx.results.plots import blank_figure, save_figure

    def heat_map(name: str) -> Path:
        figure = blank_figure((4.0, 3.0))
        axes = figure.subplots()
        image = axes.imshow([[0.0, 1.0], [2.0, 3.0]])
        figure.colorbar(image, ax=axes, label="value [m]")
        return save_figure(figure, tmp_path / name)

    plain = heat_map("plain.png").read_bytes()
    with matplotlib.rc_context({setting: True}):
        assert heat_map("set.png").read_bytes() == plain
