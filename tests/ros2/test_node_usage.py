"""``fmionnx node``, ``run --backend ros2`` and ``ros2 graph``: a usage mistake exits 2 naming
the option, before any work (docs/ros2.md: 1 is a fault, 2 a usage error).

``node`` reported a wrong COMPONENT, ``--param`` or ``--stop-time`` as a fault (exit 1), an
unknown ``--ros-distro`` as Python's enum message, and a file at ``--record-dir`` only after
the whole run (its rows lost); ``run --backend ros2`` ignored ``--rtf`` in lockstep; ``ros2
graph`` took any ``--timeout`` (``inf`` listened for ever) and blamed ROS_DOMAIN_ID for a bad
``--domain``.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli import app
from tests.ros2.test_run import fmionnx

pytestmark = pytest.mark.ros2


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["nosuch"], "the system has no component `nosuch` (it has my-src, gain)"),
        (["gain", "--stop-time", "-1"], "--stop-time -1.0 must be greater than the start time"),
        (["gain", "-p", "nosuch.v=1"], "--param `nosuch.v`: no component `nosuch`"),
        (["gain", "-p", "my-src.v.value=abc"], "`v.value` takes a number, got `abc`"),
        (
            ["gain", "--ros-distro", "foxy"],
            "--ros-distro must be one of humble, iron, jazzy, kilted",
        ),
    ],
)
def test_node_usage_errors_exit_2_naming_what_is_wrong(
    system: Path, loopback_env, args: list[str], message: str
) -> None:
    result = CliRunner().invoke(app, ["node", str(system), *args])
    assert result.exit_code == 2, result.output
    assert message in " ".join(result.output.split())
    assert "Traceback" not in result.output


def test_a_file_at_record_dir_is_refused_before_the_node_runs(
    system: Path, tmp_path: Path, loopback_env
) -> None:
    taken = tmp_path / "rows"
    taken.write_text("notes\n", encoding="utf-8")
    # Without the early check the node ran (here: waited for a /clock no one sends) first.
    done = subprocess.run(
        fmionnx("node", system, "gain", "--sync", "lockstep", "--record-dir", taken),
        capture_output=True, text=True, timeout=30, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert f"--record-dir `{taken}` exists and is not a folder" in " ".join(done.stderr.split())
    assert "ready" not in done.stderr  # refused before the node set anything up
    assert taken.read_text(encoding="utf-8") == "notes\n"


def test_rtf_is_refused_in_a_lockstep_ros2_run(system: Path, tmp_path: Path) -> None:
    for sync in ([], ["--sync", "lockstep"]):
        result = CliRunner().invoke(
            app, ["run", str(system), "--backend", "ros2", *sync, "--rtf", "2",
                  "--out", str(tmp_path / "out")],
        )  # fmt: skip
        assert result.exit_code == 2, result.output
        assert "--rtf applies to --backend ros2 --sync free only" in " ".join(result.output.split())
    assert not (tmp_path / "out").exists()  # refused before anything was made


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--timeout", "-1"], "--timeout must be a finite number of seconds > 0, not -1.0"),
        (["--timeout", "nan"], "--timeout must be a finite number of seconds > 0, not nan"),
        (["--timeout", "inf"], "--timeout must be a finite number of seconds > 0, not inf"),
        (["--domain", "300"], "--domain 300 is out of range (expected 0 to 232)"),
    ],
)
def test_ros2_graph_listening_options_are_refused_by_name(
    system: Path, loopback_env, args: list[str], message: str
) -> None:
    # A child process: `--timeout inf` listened for ever before.
    done = subprocess.run(
        fmionnx("ros2", "graph", system, *args),
        capture_output=True, text=True, timeout=30, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert message in " ".join(done.stderr.split())
    assert "ROS_DOMAIN_ID" not in done.stderr
