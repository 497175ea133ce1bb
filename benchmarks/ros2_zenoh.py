"""ROS 2 over Zenoh next to Cyclone DDS, measured side by side in one run on loopback.

Run: ``python benchmarks/ros2_zenoh.py [--quick]``. Starts a Zenoh router inside this process
(on a free port) and two echo processes, one per wire; the measuring code is
``ros2_wire.py``'s (a hop is half of a ping -> echo -> pong round trip, each side serialising
and deserialising as a node does). Prints, per wire: Twist and 640x480 rgb8 Image hop p50/p99,
images echoed per second when sent as fast as possible, and a 30 Hz camera over Zenoh for N
seconds with the frames that did not come back. Ratios, not absolute times, are the result on
a shared machine.
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import ros2_wire
from fmionnx.backends.ros2.env import from_environment
from fmionnx.backends.ros2.transport import Participant
from fmionnx.backends.ros2.zenoh.config import zenoh_environment
from fmionnx.backends.ros2.zenoh.router import InProcessRouter
from fmionnx.backends.ros2.zenoh.transport import ZenohReader, ZenohTransport

WIRES = ("zenoh", "dds")


def _zenoh(endpoint: str, name: str) -> ZenohTransport:
    return ZenohTransport(zenoh_environment(ros2_wire.DISTRO, router=endpoint), "/", name)


def _echo_child(wire: str, endpoint: str) -> subprocess.Popen[str]:
    if wire == "dds":
        argv = [sys.executable, ros2_wire.__file__, "--echo"]
    else:
        argv = [sys.executable, __file__, "--echo", endpoint]
    child = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
    assert child.stdout is not None
    child.stdout.readline()  # "ready"
    return child


def _measure(participant: Any, frame: np.ndarray, quick: bool) -> dict[str, Any]:
    twist = ros2_wire._hops(participant, "twist", ros2_wire.TWIST, {"v": np.array(0.5)},
                            100 if quick else 500)  # fmt: skip
    image = ros2_wire._hops(participant, "image", ros2_wire.IMAGE, {"img": frame},
                            20 if quick else 100)  # fmt: skip
    seconds = 1.0 if quick else 3.0
    _, back = ros2_wire._throughput(participant, 10_000.0, seconds, frame)
    return {
        "twist": ros2_wire._percentiles(twist),
        "image": ros2_wire._percentiles(image),
        "images_per_s": back / seconds,
    }


def main(argv: list[str] | None = None, console: Console | None = None) -> dict[str, Any]:
    """Measure both wires; the figures by wire (also printed as a table)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer samples, 2 s camera")
    parser.add_argument("--seconds", type=float, help="30 Hz camera duration (default 10)")
    args = parser.parse_args(argv)
    console = console or Console()
    camera_seconds = args.seconds or (2.0 if args.quick else 10.0)
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(100, 230)))
    os.environ["ROS_LOCALHOST_ONLY"] = "1"
    frame = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    router = InProcessRouter()
    results: dict[str, Any] = {}
    children: list[subprocess.Popen[str]] = []
    try:
        for wire in WIRES:
            children.append(_echo_child(wire, router.endpoint))
            if wire == "zenoh":
                with _zenoh(router.endpoint, "bench_ping") as participant:
                    results[wire] = _measure(participant, frame, args.quick)
                    results["camera"] = ros2_wire._throughput(
                        participant, 30.0, camera_seconds, frame
                    )
                    results["shared_memory"] = sum(
                        r.shared_memory_samples for r in participant.entities
                        if isinstance(r, ZenohReader)
                    )  # fmt: skip
            else:
                with Participant(from_environment(ros2_wire.DISTRO)) as participant:
                    results[wire] = _measure(participant, frame, args.quick)
    finally:
        for child in children:
            child.kill()
            child.communicate()  # reaps it and closes its pipe
        router.close()
    _print(console, results, camera_seconds)
    return results


def _print(console: Console, results: dict[str, Any], camera_seconds: float) -> None:
    table = Table(title="ROS 2 wire on loopback: Zenoh (rmw_zenoh wire) vs Cyclone DDS")
    table.add_column("measurement")
    for wire in WIRES:
        table.add_column(f"{wire} p50", justify="right")
        table.add_column(f"{wire} p99", justify="right")
    table.add_column("zenoh / dds (p50)", justify="right")
    zenoh, dds = results["zenoh"], results["dds"]
    for key, label in (("twist", "Twist hop (ms)"), ("image", "640x480 rgb8 Image hop (ms)")):
        ratio = zenoh[key][0] / dds[key][0]
        table.add_row(label, *(f"{v:.3f}" for v in (*zenoh[key], *dds[key])), f"{ratio:.2f}")
    table.add_row(
        "images/s echoed, sent flat out", f"{zenoh['images_per_s']:.0f}", "",
        f"{dds['images_per_s']:.0f}", "", f"{zenoh['images_per_s'] / dds['images_per_s']:.2f}",
    )  # fmt: skip
    console.print(table)
    sent, back = results["camera"]
    verdict = "no frame dropped" if back >= sent else f"{sent - back} frame(s) dropped"
    console.print(
        f"30 Hz camera over Zenoh for {camera_seconds:g} s: {sent} frames sent, {back} back "
        f"({verdict})"
    )
    console.print(
        f"Zenoh samples received through shared memory: {results['shared_memory']} "
        "(payloads above 3 KB between peers on this host)"
    )


if __name__ == "__main__":
    if "--echo" in sys.argv:
        endpoint = sys.argv[sys.argv.index("--echo") + 1]
        with _zenoh(endpoint, "bench_echo") as transport:
            ros2_wire.echo_on(transport)
    else:
        main()
