"""Three gaps of ROS 2 mode, each checked on the real part.

* An explicit ``ros2.topics`` entry putting an ``int64`` port onto a ``float64`` field (or an
  ``int32`` onto ``float32``, an ``int64`` onto ``int32``, a float onto an integer field)
  changed values above the field's reach without a word: now W060, at the entry.
* ``fmionnx node --sync lockstep --rtf X`` was taken (and the pace ignored), while
  ``fmionnx run --backend ros2`` refuses ``--rtf`` in lockstep: now a usage error, except for
  the supervisor's own ``--supervised`` nodes, which it hands ``--rtf`` in every mode.
* ``fmionnx ros2 graph`` called a link ``ok`` whatever its message type, though DDS matches no
  ``std_msgs/msg/Int64`` reader with a ``std_msgs/msg/Float64`` writer: now a ``type`` row
  with both types, and exit 1.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.backends.ros2.discovery import GraphAnnouncer, NodeEntities
from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.graph import LiveGraph, compare, render_json, render_text
from fmionnx.backends.ros2.loading import plan_for
from fmionnx.backends.ros2.transport import Participant
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import PROFILES
from fmionnx.compile.ros2.types import Ros2Plan
from tests.conftest import build_fixture_fmu, cli
from tests.ros2.test_run import fmionnx

#: Two Types3 FMUs (one port of every element type) chained by their integer ports.
CHAIN = """\
fmionnx: 1
name: wide
run: {{stop: 0.2, step: 0.1}}
components:
  a: {{kind: fmu, path: {fmu}}}
  b: {{kind: fmu, path: {fmu}}}
connections:
  - a.y_i64 -> b.u_i64
  - a.y_i32 -> b.u_i32
  - a.y_u64 -> b.u_u64
  - a.y_i16 -> b.u_i16
  - a.y_u32 -> b.u_u32
  - a.y_f32 -> b.u_f32
{ros2}"""

LOSSY = """\
ros2:
  topics:
    a.y_i64: {topic: /big, type: std_msgs/msg/Float64}
    a.y_i32: {topic: /i32, type: std_msgs/msg/Float32}
    a.y_u64: {topic: /narrow, type: std_msgs/msg/Int32}
    a.y_f32: {topic: /cut, type: std_msgs/msg/Int32}
    a.y_i16: {topic: /small, type: std_msgs/msg/Float32}
    a.y_u32: {topic: /vel, type: geometry_msgs/msg/Twist, field: linear.x}
    b.u_i8: {topic: /outside, type: std_msgs/msg/Float64}
"""


def _chain(folder: Path, ros2: str = "") -> Path:
    path = folder / "wide.yaml"
    path.write_text(CHAIN.format(fmu=build_fixture_fmu("Types3"), ros2=ros2), encoding="utf-8")
    return path


# --- 1. W060: a field that cannot hold every value of its port


def test_explicit_mapping_onto_a_narrower_field_warns_at_the_entry(tmp_path: Path) -> None:
    path = _chain(tmp_path, LOSSY)
    code, output = cli("validate", str(path), "--format", "json")
    assert code == 0, output  # a warning: the mapping is allowed, it is not silent any more
    found = {
        d["message"].split("`")[1]: d
        for f in json.loads(output)["files"]
        for d in f["diagnostics"]
        if d["code"] == "W060"
    }
    assert set(found) == {"a.y_i64", "a.y_i32", "a.y_u64", "a.y_f32", "b.u_i8"}
    lines = path.read_text(encoding="utf-8").splitlines()
    for port, diagnostic in found.items():  # at the entry of that port in `ros2.topics`
        assert lines[diagnostic["line"] - 1].lstrip().startswith(f"{port}:"), diagnostic
    big = found["a.y_i64"]
    assert "`data` of `std_msgs/msg/Float64`" in big["message"]
    assert "cannot hold every int64 value: integers beyond 2^53 arrive rounded" in big["message"]
    assert "`std_msgs/msg/Int64`" in big["hint"]
    assert "beyond 2^24" in found["a.y_i32"]["message"]
    assert "outside the range of int32" in found["a.y_u64"]["message"]
    assert "`std_msgs/msg/UInt64`" in found["a.y_u64"]["hint"]
    assert "fractions are cut off" in found["a.y_f32"]["message"]
    assert "reads `data` of `std_msgs/msg/Float64`" in found["b.u_i8"]["message"]


def test_mappings_that_hold_every_value_stay_quiet(tmp_path: Path) -> None:
    exact = (
        "ros2:\n  topics:\n"
        "    a.y_i64: {topic: /big, type: std_msgs/msg/Int64}\n"
        "    a.y_u32: {topic: /wide, type: std_msgs/msg/Int64}\n"
        "    a.y_f32: {topic: /f, type: std_msgs/msg/Float64}\n"
        "    a.y_i16: /small\n"
    )
    code, output = cli("validate", str(_chain(tmp_path, exact)))
    assert code == 0, output
    assert "W060" not in output


# --- 2. `fmionnx node --rtf` in lockstep


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--rtf", "2"], "--rtf applies to --sync free only (lockstep is not paced)"),
        (["--input-wait", "0.5"], "--input-wait applies to --sync free only"),
    ],
)
def test_a_hand_started_lockstep_node_refuses_free_run_options(
    system: Path, option: list[str], message: str
) -> None:
    # `nosuch`: without the check the node gets as far as the component (exit 2 too, but
    # naming the component), never into a lockstep run that waits for a supervisor.
    code, output = cli("node", str(system), "nosuch", "--sync", "lockstep", *option)
    assert code == 2, output
    assert message in output
    assert "nosuch" not in output  # refused before the system was read


@pytest.mark.parametrize(
    "args",
    [
        ["--sync", "lockstep", "--supervised", "--rtf", "1.0"],  # as the supervisor starts them
        ["--sync", "free", "--rtf", "2", "--input-wait", "0.5"],
    ],
)
def test_supervised_and_free_nodes_still_take_rtf(system: Path, args: list[str]) -> None:
    # An unknown component is the next thing checked: reaching it means the options passed.
    code, output = cli("node", str(system), "nosuch", *args)
    assert code == 2, output
    assert "the system has no component `nosuch`" in output
    assert "applies to --sync free only" not in output


# --- 3. `fmionnx ros2 graph` compares message types


def _plan_and_graph(folder: Path, a_type: str) -> tuple[Ros2Plan, LiveGraph]:
    plan = plan_for(api.load(_chain(folder)).compiled, RosDistro.HUMBLE)
    graph = LiveGraph(nodes={"/a", "/b"})
    for node in plan.nodes:
        for kind, topics in (("pub", node.publishes), ("sub", node.subscribes)):
            for topic in topics:
                msgtype = plan.topic(topic).msgtype
                if node.fqn == "/a" and topic == "/a/y_i64":
                    msgtype = a_type  # an older fmionnx: every number as Float64
                link = (node.fqn, kind, topic)
                graph.links.add(link)
                graph.link_types.setdefault(link, set()).add(msgtype)
                graph.topics.setdefault(topic, set()).add(msgtype)
    return plan, graph


def test_graph_reports_a_link_of_another_message_type(tmp_path: Path) -> None:
    plan, graph = _plan_and_graph(tmp_path, "std_msgs/msg/Float64")
    result = compare(plan, graph)
    assert not result.complete
    assert ("/a", "pub", "/a/y_i64") not in result.ok
    assert ("/b", "sub", "/a/y_i64") in result.ok  # its own reader's type is right
    (wrong,) = result.wrong_type
    assert (wrong.link, wrong.expected, wrong.seen) == (
        ("/a", "pub", "/a/y_i64"),
        "std_msgs/msg/Int64",
        ("std_msgs/msg/Float64",),
    )
    text = render_text(plan, graph, result)
    assert (
        "  type     /a -> /a/y_i64  seen std_msgs/msg/Float64, expected std_msgs/msg/Int64\n"
        in text
    )
    assert text.endswith(f"{len(result.ok)} link(s) ok, 0 missing, 0 extra, 1 of the wrong type\n")


def test_graph_of_matching_types_is_unchanged(tmp_path: Path) -> None:
    plan, graph = _plan_and_graph(tmp_path, "std_msgs/msg/Int64")
    result = compare(plan, graph)
    assert result.complete
    assert result.wrong_type == ()
    text = render_text(plan, graph, result)
    assert "type " not in text
    assert text.endswith(f"{len(result.ok)} link(s) ok, 0 missing, 0 extra\n")
    assert json.loads(render_json(plan, graph, result))["wrong_type"] == []


@pytest.mark.ros2
def test_graph_over_dds_flags_a_float64_writer_of_an_int64_port(
    tmp_path: Path, loopback_env
) -> None:
    system = _chain(tmp_path)
    # What an older fmionnx node `/a` put on the wire: its int64 port as std_msgs/msg/Float64.
    participant = Participant(from_environment(RosDistro.HUMBLE))
    try:
        writer = participant.writer("rt/a/y_i64", "std_msgs/msg/Float64", PROFILES["default"])
        announcer = GraphAnnouncer(participant)  # kept: its writer holds the sample
        announcer.add_node(NodeEntities("/", "a", [], [writer.gid]))
        done = subprocess.run(
            fmionnx("ros2", "graph", system, "--format", "json", "--timeout", "2",
                    "--ros-distro", "humble"),
            capture_output=True, text=True, timeout=60, check=False,
        )  # fmt: skip
    finally:
        participant.close()
    assert done.returncode == 1, done.stderr
    report = json.loads(done.stdout)
    assert report["wrong_type"] == [
        {
            "node": "/a",
            "kind": "pub",
            "topic": "/a/y_i64",
            "expected": "std_msgs/msg/Int64",
            "seen": ["std_msgs/msg/Float64"],
        }
    ]
    assert {"node": "/a", "kind": "pub", "topic": "/a/y_i64"} not in report["ok"]


def test_w060_judges_each_entry_by_its_own_field_when_ports_share_a_name(tmp_path: Path) -> None:
    """Two components' ports named alike on one topic: the field of the entry was looked up by
    port name alone, so the other component's field was judged (a review): `b.u_i32` reading
    `nanosec` (uint32) went unwarned, or `a.u_i32` was blamed for it."""
    fmu = build_fixture_fmu("Types3")
    path = tmp_path / "shared.yaml"
    for first, second in (("a", "b"), ("b", "a")):
        path.write_text(
            "fmionnx: 1\nname: shared\nrun: {stop: 0.2, step: 0.1}\ncomponents:\n"
            f"  a: {{kind: fmu, path: {fmu}}}\n  b: {{kind: fmu, path: {fmu}}}\n"
            "ros2:\n  topics:\n"
            f"    {first}.u_i32: {{topic: /stamp, type: builtin_interfaces/msg/Time, "
            f"field: {'sec' if first == 'a' else 'nanosec'}}}\n"
            f"    {second}.u_i32: {{topic: /stamp, type: builtin_interfaces/msg/Time, "
            f"field: {'sec' if second == 'a' else 'nanosec'}}}\n",
            encoding="utf-8",
        )
        code, output = cli("validate", str(path), "--format", "json")
        assert code == 0, output
        warned = [
            d["message"]
            for f in json.loads(output)["files"]
            for d in f["diagnostics"]
            if d["code"] == "W060"
        ]
        assert len(warned) == 1, warned
        assert warned[0].startswith("`b.u_i32` (int32) reads `nanosec`"), warned
