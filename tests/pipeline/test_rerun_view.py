"""``--rrd``: the run as a Rerun recording, read back through Rerun's own reader.

The reference scenario for one simulated second (500 base steps of 2 ms, the camera at
10 Hz): every recorded signal is a time series of 101 rows (one every 5 base steps, 100 a
simulated second), the camera has 10 frames, the map, the sites, the expected path and the
graph are there once, the checks when the run ended.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app

rerun_chunk = pytest.importorskip("rerun.chunk")  # the `view` extra (in the test extras)

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def recording(
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[str, tuple[bool, int, list[object]]]:
    here = tmp_path_factory.mktemp("rrd")
    rrd = here / "run.rrd"
    result = CliRunner().invoke(
        app,
        ["run", str(REPO / "systems" / "sign_follower.yaml"), "--stop-time", "1",
         "--out", str(here / "out"), "--rrd", str(rrd)],
    )  # fmt: skip
    assert result.exit_code == 1, result.output  # 1 s: B is not reached, a check fails
    assert f"wrote {rrd}" in " ".join(result.output.split()).replace("│ ", "")
    entities: dict[str, tuple[bool, int, list[object]]] = {}
    rows: Counter[str] = Counter()
    for chunk in rerun_chunk.RrdReader(rrd).store().stream():
        path = str(chunk.entity_path)
        rows[path] += chunk.num_rows
        batch = chunk.to_record_batch()
        entities[path] = (bool(chunk.is_static), rows[path], batch.schema.names)
    assert not list(here.glob(".run.rrd.*")), "the partial file was renamed"
    return entities


def test_every_signal_is_a_time_series_under_its_component(recording) -> None:
    for entity in ("/odometry/posX", "/tracker/v", "/world/base_pos/0", "/detector/blobX/0/2"):
        static, rows, columns = recording[entity]
        assert not static
        assert rows == 101, entity  # base steps 0, 5, ..., 500
        assert "sim_time" in columns
        assert "Scalars:scalars" in columns


def test_the_camera_frames_are_images_on_the_simulation_timeline(recording) -> None:
    static, rows, columns = recording["/world/front"]
    assert not static
    # t = 0, 0.1, ..., 0.9, and t = 0 once more: the initial frame the detector evaluates
    # its start outputs on (docs/execution.md, "Initial values")
    assert rows == 11
    assert "sim_time" in columns
    assert any(str(c).startswith("EncodedImage:") for c in columns)


def test_the_course_is_drawn_as_the_trajectory_plot_draws_it(recording) -> None:
    for entity in ("/map/landmarks", "/map/sites", "/map/expected_path"):
        static, rows, _ = recording[entity]
        assert static
        assert rows == 1
    static, rows, columns = recording["/map/trajectory"]
    assert not static
    assert rows >= 1
    assert "LineStrips2D:strips" in columns


def test_the_graph_and_the_checks_are_there(recording) -> None:
    static, _, columns = recording["/graph"]
    assert static
    assert {"GraphNodes:node_ids", "GraphEdges:edges"} <= set(map(str, columns))
    for name in ("/checks", "/checks/reaches\\ B", "/checks/stops", "/run"):
        assert name in recording, sorted(recording)


def test_the_graph_names_every_component(tmp_path: Path) -> None:
    """Read one entity's values: the graph's nodes and edges."""
    rrd = tmp_path / "run.rrd"
    result = CliRunner().invoke(
        app,
        ["run", str(REPO / "systems" / "sign_follower.yaml"), "--stop-time", "0.01",
         "--no-out", "--no-checks", "--rrd", str(rrd)],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    graph = next(
        c.to_record_batch()
        for c in rerun_chunk.RrdReader(rrd).store().stream()
        if str(c.entity_path) == "/graph"
    )
    nodes = graph.column("GraphNodes:node_ids").to_pylist()[0]
    assert sorted(nodes) == ["detector", "odometry", "tracker", "world"]
    edges = graph.column("GraphEdges:edges").to_pylist()[0]
    assert sorted((e["first"], e["second"]) for e in edges) == [
        ("detector", "tracker"), ("odometry", "tracker"), ("tracker", "world"),
        ("world", "detector"), ("world", "odometry"),
    ]  # one edge per pair of components a connection joins  # fmt: skip


#: ``python -c`` this, then a program and its arguments: runs it with SIGINT's default action.
RESTORE_SIGINT_AND_EXEC = (
    "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
    "os.execv(sys.argv[1], sys.argv[1:])"
)


def test_a_remote_viewer_takes_the_run(tmp_path: Path) -> None:
    """`--view rerun+tcp://HOST:PORT` against a real, headless Rerun server (`rerun --port P
    --save FILE`: it takes SDK connections as a viewer does and writes what reaches it): the
    run streams to it, ends normally, and everything it sent arrived (0.3 s: frames at t = 0,
    0.1, 0.2 and 31 rows of each signal)."""
    import shutil
    import signal
    import socket
    import subprocess
    import sys
    import time
    import warnings

    from tests.conftest import finish

    rerun = shutil.which("rerun", path=str(Path(sys.executable).parent))
    assert rerun is not None
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    received = tmp_path / "received.rrd"
    log = (tmp_path / "server.log").open("w")  # a pipe nobody reads would fill and block it
    # It ends on Ctrl-C, even where this process was started with SIGINT ignored (a background
    # job of a shell without job control: the ignored signal is handed to every program
    # started from it, and Rerun keeps it so): the server is exec'd from a Python that
    # restores the default first.
    server = subprocess.Popen(
        [sys.executable, "-c", RESTORE_SIGINT_AND_EXEC, rerun, "--port", str(port),
         "--save", str(received)], stdout=log, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        while True:
            with socket.socket() as client:
                if client.connect_ex(("127.0.0.1", port)) == 0:
                    break
            assert time.monotonic() < deadline, "the Rerun server did not start listening"
            time.sleep(0.2)
        run = subprocess.run(
            [sys.executable, "-m", "fmionnx", "run", str(REPO / "systems" / "sign_follower.yaml"),
             "--stop-time", "0.3", "--no-out", "--no-checks", "-q",
             "--view", f"rerun+tcp://127.0.0.1:{port}"],
            capture_output=True, text=True, timeout=300, check=False,
        )  # fmt: skip
    finally:
        server.send_signal(signal.SIGINT)  # its Ctrl-C: it ends the file it writes
        try:
            finish(server, 60)
        finally:
            log.close()
    assert run.returncode == 0, run.stderr[-3000:]
    assert "not everything reached the viewer" not in run.stderr
    rows: Counter[str] = Counter()
    with warnings.catch_warnings():  # a streamed file has no index at its end: Rerun says so
        warnings.simplefilter("ignore")
        reader = rerun_chunk.RrdReader(received)
    for chunk in reader.stream().collect().stream():
        rows[str(chunk.entity_path)] += chunk.num_rows
    assert rows["/world/front"] == 4  # t = 0 (twice: the detector's start), 0.1, 0.2
    assert rows["/odometry/posX"] == rows["/tracker/v"] == 31
    assert rows["/graph"] == rows["/map/sites"] == rows["/run"] == 1
