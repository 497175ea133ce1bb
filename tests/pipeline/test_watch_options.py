"""The watching options as a request takes them: --view, --rrd, --profile, --on-nonfinite.

Refusals are usage errors (exit 2) naming the option; a view whose library is missing names
the command that installs it; the ROS 2 backend (whose topics are on the wire) refuses a live
view; a lone FMU's default (the guardian) gives way to a view, and an explicit guardian is
refused with one. The MCAP recording carries the channels the live server publishes.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from typer.testing import CliRunner

from fmionnx.cli import app
from fmionnx.pipeline.errors import RequestError
from fmionnx.pipeline.request import build_request
from fmionnx.pipeline.viewspec import ViewSpecError, parse_view

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("text", "kind", "url", "port"),
    [
        ("rerun", "rerun", None, 8765),
        ("rerun+tcp://10.0.0.2:9876", "rerun", "rerun+http://10.0.0.2:9876/proxy", 8765),
        ("rerun+http://viewer.local:9000/proxy", "rerun", "rerun+http://viewer.local:9000/proxy", 8765),
        ("foxglove", "foxglove", None, 8765),
        ("foxglove:0", "foxglove", None, 0),
        ("foxglove:9090", "foxglove", None, 9090),
    ],
)  # fmt: skip
def test_views_are_read_from_one_word(text: str, kind: str, url: str | None, port: int) -> None:
    target = parse_view(text)
    assert (target.kind, target.url, target.port) == (kind, url, port)


@pytest.mark.parametrize("text", ["rviz", "rerun+tcp://host", "foxglove:70000", "rerun+tcp://h:0"])
def test_a_word_that_names_no_view_is_refused(text: str) -> None:
    with pytest.raises(ViewSpecError, match="--view"):
        parse_view(text)


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"view": "rviz"}, "--view takes `rerun`, `rerun+tcp://HOST:PORT`, `foxglove`"),
        ({"view": ["rerun", "rerun"]}, "--view names each kind of view once"),
        ({"on_nonfinite": "ignore"}, "--on-nonfinite must be `fault` or `warn`"),
        ({"profile": "yes"}, "--profile is true or false"),
        ({"rtf": -1.0}, "--rtf must be a finite number >= 0"),
        ({"rtf": float("nan")}, "--rtf must be a finite number >= 0"),
        ({"backend": "ros2", "view": "foxglove"}, "--view and --rrd show in-process runs"),
        ({"backend": "ros2", "rrd": "x.rrd"}, "--view and --rrd show in-process runs"),
    ],
)
def test_bad_watching_options_are_refused_by_name(
    settings: dict[str, object], message: str
) -> None:
    with pytest.raises(RequestError, match=message.replace("+", r"\+").replace("(", r"\(")):
        build_request(REPO / "systems" / "sign_follower.yaml", **settings)


def test_rtf_is_an_option_of_both_backends() -> None:
    """ROS 2 paces a free run only (lockstep refuses `--rtf`: docs/ros2.md)."""
    system = REPO / "systems" / "sign_follower.yaml"
    for backend, more in (("inprocess", {}), ("ros2", {"sync": "free"})):
        request = build_request(system, backend=backend, rtf=2.0, **more)
        assert request.backend_options.rtf == 2.0  # type: ignore[attr-defined]


def test_a_missing_viewer_library_names_the_install_command(tmp_path: Path) -> None:
    """A fresh interpreter in which `rerun` cannot be imported (as without the extra)."""
    probe = f"""
import sys
sys.modules["rerun"] = None  # an import of it fails, as when it is not installed
from fmionnx.cli import main
sys.argv = ["fmionnx", "run", {str(REPO / "systems" / "sign_follower.yaml")!r}, "--no-out",
            "--rrd", {str(tmp_path / "x.rrd")!r}]
main()
"""
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 2, done.stderr
    text = " ".join(done.stderr.split())
    assert "--rrd needs the `rerun-sdk` package, which is not installed" in text
    assert "pip install -e '.[view]'" in text
    assert not (tmp_path / "x.rrd").exists()


def test_a_plain_run_imports_no_viewer_library(tmp_path: Path) -> None:
    probe = f"""
import json, sys
from fmionnx.cli import main
sys.argv = ["fmionnx", "run", {str(REPO / "systems" / "sign_follower.yaml")!r}, "--no-out",
            "--stop-time", "0.01", "--no-checks", "--profile", "--rtf", "1000"]
try:
    main()
except SystemExit:
    pass
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in ("rerun", "foxglove", "websockets"))))
"""
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, check=False
    )
    assert json.loads(done.stdout.strip().splitlines()[-1]) == [], done.stderr[-2000:]


def test_a_view_keeps_a_lone_fmu_out_of_the_guardian(fixture_fmu, tmp_path: Path) -> None:
    fmu = fixture_fmu("Gain")
    rrd = tmp_path / "gain.rrd"
    result = CliRunner().invoke(
        app, ["run", str(fmu), "--out", str(tmp_path / "out"), "--rrd", str(rrd)]
    )
    assert result.exit_code == 0, result.output
    info = json.loads((tmp_path / "out" / "run.json").read_text())
    assert info["execution"]["isolate"] == "fmus"  # not the guardian: the rows must reach the view
    assert rrd.exists()
    refused = CliRunner().invoke(
        app,
        ["run", str(fmu), "--no-out", "--isolate", "guardian", "--rrd", str(tmp_path / "g.rrd")],
    )
    assert refused.exit_code == 2
    assert "--isolate guardian does not combine with --view or --rrd" in " ".join(
        refused.output.split()
    )


def test_the_mcap_recording_carries_the_live_channels(tmp_path: Path) -> None:
    record = tmp_path / "run.mcap"
    result = CliRunner().invoke(
        app,
        ["run", str(REPO / "systems" / "sign_follower.yaml"), "--stop-time", "1.2",
         "--out", str(tmp_path / "out"), "--record", str(record)],
    )  # fmt: skip
    assert result.exit_code == 1, result.output  # 1.2 s: B is not reached
    with record.open("rb") as stream:
        messages = list(make_reader(stream).iter_messages())
    by_topic: dict[str, list[bytes]] = {}
    schemas: dict[str, str] = {}
    for schema, channel, message in messages:
        by_topic.setdefault(channel.topic, []).append(message.data)
        assert schema is not None
        schemas[channel.topic] = schema.name
    assert len(by_topic["/world/front"]) == 13  # t = 0 twice (the detector's start), to 1.1
    assert len(by_topic["/signals"]) == 121  # 100 rows a simulated second, and t=0
    assert schemas["/map"] == "foxglove.SceneUpdate"
    assert schemas["/trajectory"] == "foxglove.PosesInFrame"
    scene = json.loads(by_topic["/map"][0])
    texts = [t["text"] for t in scene["entities"][0]["texts"]]
    assert {"A", "B"} <= set(texts)
    assert scene["entities"][0]["lines"]  # the sign boards' outlines and the expected path
    path = json.loads(by_topic["/trajectory"][-1])
    assert len(path["poses"]) == 13  # 10 points a simulated second: t = 0, 0.1, ..., 1.2
    graph = json.loads(by_topic["/graph"][0])
    assert {n["id"] for n in graph["nodes"]} == {"world", "odometry", "detector", "tracker"}
    checks = json.loads(by_topic["/checks"][0])
    assert [c["name"] for c in checks["checks"]] == ["reaches B", "stops", "stays on the path"]


def test_an_unreachable_viewer_is_refused_before_the_run(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setattr("fmionnx.pipeline.views.VIEWER_WAIT", 0.5)
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    result = CliRunner().invoke(
        app,
        ["run", str(REPO / "systems" / "sign_follower.yaml"), "--out", str(tmp_path / "out"),
         "--view", f"rerun+tcp://127.0.0.1:{port}"],
    )  # fmt: skip
    assert result.exit_code == 1
    text = " ".join(result.output.split())
    assert (
        f"--view rerun+tcp://127.0.0.1:{port}: no Rerun viewer answers at 127.0.0.1:{port}" in text
    )
    assert not (tmp_path / "out").exists()  # refused before anything ran


def test_a_foxglove_port_in_use_is_refused_with_the_way_out(tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = CliRunner().invoke(
            app,
            ["run", str(REPO / "systems" / "sign_follower.yaml"), "--no-out", "--no-checks",
             "--stop-time", "0.1", "--view", f"foxglove:{port}"],
        )  # fmt: skip
    assert result.exit_code == 1
    text = " ".join(result.output.split())
    assert f"--view foxglove: cannot serve on 127.0.0.1:{port}" in text
    assert "choose another port with --view foxglove:PORT (0: any free one)" in text
