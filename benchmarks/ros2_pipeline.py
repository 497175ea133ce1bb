"""Camera frame published -> ``/cmd_vel`` received, through the reference system's real nodes.

Run: ``python benchmarks/ros2_pipeline.py`` (about a minute; domain chosen at random, traffic
kept on 127.0.0.1). Prints one table per camera rate.

``systems/sign_follower.yaml`` with the world marked ``external: true`` runs as three
``fmionnx node ... --sync free`` processes (odometry, detector, tracker). This script plays the
simulator node of a free run: at real time, every world step (2 ms) it publishes ``/clock``,
at the detector's grid points a 640x480 ``rgb8`` frame on ``/camera/image_raw`` *before* that
tick (the order the simulator node uses), and ``/odom`` at 100 Hz. For a 30 Hz camera the
detector's period is set to 1/30 s (base step 1/1500 s, so that 1/30 s is on the grid); at
10 Hz the system is the reference one.

Matching answers to frames: ``/cmd_vel`` has no header and the tracker publishes it at its own
100 Hz, so each frame carries one blue board at its own column (a cycle of positions). The
detector reports that column in ``/onnx_blobX``; the tracker, approaching the board, steers
``w = -0.6 (x - 319.5) / 320``, a value unique to the position. A frame's answer is the first
message carrying its value received after it was published; a frame with no ``/cmd_vel``
answer is dropped. Latencies are taken in this process (one ``perf_counter``, a listener
thread per topic).
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import math
import os
import random
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script

import fmionnx  # noqa: E402
from fmionnx.backends.ros2.codec import TopicCodec  # noqa: E402
from fmionnx.backends.ros2.control import CLOCK_DDS, CONTROL_WRITER_QOS, StepClock  # noqa: E402
from fmionnx.backends.ros2.env import from_environment  # noqa: E402
from fmionnx.backends.ros2.loading import plan_for  # noqa: E402
from fmionnx.backends.ros2.transport import Participant, RawReader  # noqa: E402
from fmionnx.compile.ir import RunSettings  # noqa: E402
from fmionnx.compile.ros2.messages import RosDistro  # noqa: E402
from fmionnx.compile.ros2.names import dds_topic  # noqa: E402
from fmionnx.compile.ros2.plan import CLOCK_TYPE  # noqa: E402
from fmionnx.compile.ros2.types import Ros2Plan, TopicPlan  # noqa: E402

SYSTEM = REPO / "systems" / "sign_follower.yaml"
DISTRO = RosDistro.HUMBLE
NODES = ("odometry", "detector", "tracker")
WORLD_PERIOD = 0.002  # the scene's physics step: the simulator node's /clock period
ODOM_PERIOD = 0.01  # the odometry FMU's period
FINE_STEP = 1 / 1500  # a base step on which 2 ms, 10 ms and 1/30 s all lie
LATE = 0.005  # a frame published this much after its instant counts as late (a loaded host)

#: DDS configurations compared (``CYCLONEDDS_URI`` for every process; None: not set). fmionnx's
#: Humble localhost configuration keeps multicast for discovery only (``AllowMulticast=spdp``).
#: With data by multicast too (``rmw_cyclonedds_cpp``'s Humble setting), Cyclone sends a
#: sample with two or more readers in another process by multicast: ``/clock`` (three readers)
#: then travels on another socket than the camera frame (one reader) and can overtake it.
DDS_CONFIGS: dict[str, str | None] = {
    "default": None,
    "AllowMulticast=true": (
        "<CycloneDDS><Domain><General><AllowMulticast>true</AllowMulticast></General>"
        "</Domain></CycloneDDS>"
    ),
}

#: Blue board (the detector's blue box: R <= 40, G <= 55, B >= 50) on grey; 40 x 60 pixels
#: gives blob size sqrt(2 * 2400) = 69 (>= detectSize 60: approach; < actionSize 300: no turn).
BOARD = (20, 20, 220)
BOARD_W, BOARD_H = 40, 60
#: Left column of the board in successive frames; none centred (w would be 0, as in search).
POSITIONS = tuple(range(30, 580, 12))
APPROACH_GAIN = 0.6  # SignTrackingLogic's approachGain default
HALF = 320.0  # half the image width


def board_column(position: int) -> float:
    """The detector's blobX for a board whose left column is ``position`` (mean column)."""
    return position + (BOARD_W - 1) / 2


def steering(position: int) -> float:
    """The tracker's ``w`` while approaching that board (no clamp: |w| <= 0.6 < turnRate)."""
    return -APPROACH_GAIN * ((board_column(position) - (HALF - 0.5)) / HALF)


def frame_with_board(position: int) -> np.ndarray:
    """A 480x640 rgb8 frame: grey, one blue board at ``position``."""
    frame = np.full((480, 640, 3), 128, dtype=np.uint8)
    frame[200 : 200 + BOARD_H, position : position + BOARD_W] = BOARD
    return frame


def variant_text(rate: float, stop: float) -> str:
    """The reference system file, world external, detector at ``rate`` Hz, absolute paths."""
    text = SYSTEM.read_text(encoding="utf-8").replace("../", f"{REPO.as_posix()}/")
    period = 1.0 / rate
    on_grid = math.isclose(period / 0.002, round(period / 0.002), abs_tol=1e-9)
    step = 0.002 if on_grid else FINE_STEP
    replacements = [
        (
            "run: {start: 0, stop: 32, step: 0.002}",
            f"run: {{start: 0, stop: {stop!r}, step: {step!r}}}",
        ),
        (
            "    kind: mujoco\n",
            f"    kind: mujoco\n    external: true\n    period: {WORLD_PERIOD}\n",
        ),
        ("    period: 0.1                             # a 10 Hz camera", f"    period: {period!r}"),
    ]
    for old, new in replacements:
        if old not in text:
            msg = f"{SYSTEM.name} changed: cannot find {old!r}"
            raise RuntimeError(msg)
        text = text.replace(old, new, 1)
    return text


# -- matching answers to frames -----------------------------------------------------------------


@dataclass
class Answers:
    """Per frame: when it was published, and when each watched topic first answered it."""

    published: list[float]
    positions: list[int]
    answered: dict[str, list[float | None]] = field(default_factory=dict)

    def latencies_ms(self, topic: str, frames: range) -> list[float]:
        """Answer latencies of ``frames`` on ``topic`` (answered frames only)."""
        times = self.answered[topic]
        return [(done - self.published[k]) * 1e3 for k in frames if (done := times[k]) is not None]

    def missing(self, topic: str, frames: range) -> int:
        """Frames of ``frames`` that ``topic`` never answered."""
        return sum(1 for k in frames if self.answered[topic][k] is None)


def match(
    published: Sequence[float],
    positions: Sequence[int],
    received: Sequence[tuple[float, float]],
    position_of: Callable[[float], int | None],
) -> list[float | None]:
    """First answer time per frame.

    ``received`` holds (time, value) in arrival order; ``position_of`` maps a value to the board
    position it answers (None: no board, e.g. the tracker still searching). A value answers the
    latest frame with that position published before it arrived, if not answered yet.
    """
    answered: list[float | None] = [None] * len(published)
    latest: dict[int, int] = {}
    k = 0
    for when, value in received:
        while k < len(published) and published[k] <= when:
            latest[positions[k]] = k
            k += 1
        position = position_of(value)
        frame = latest.get(position) if position is not None else None
        if frame is not None and answered[frame] is None:
            answered[frame] = when
    return answered


def nearest_position(expected: dict[int, float], tolerance: float) -> Callable[[float], int | None]:
    """``value -> position`` for the position whose expected value is within ``tolerance``."""
    ordered = sorted((value, position) for position, value in expected.items())
    keys = [value for value, _ in ordered]

    def lookup(value: float) -> int | None:
        i = bisect.bisect_left(keys, value)
        for j in (i - 1, i):
            if 0 <= j < len(keys) and abs(keys[j] - value) <= tolerance:
                return ordered[j][1]
        return None

    return lookup


# -- DDS side -----------------------------------------------------------------------------------


class Listener(threading.Thread):
    """Stamps every sample of one reader on arrival (decoding waits until the run is over)."""

    def __init__(self, reader: RawReader) -> None:
        super().__init__(daemon=True)
        self.reader = reader
        self.samples: list[tuple[float, bytes]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        """Wait, stamp, take, until stopped."""
        while not self.stop.is_set():
            if self.reader.wait(0.1):
                now = time.perf_counter()
                self.samples.extend((now, data) for data in self.reader.take(256))


def _codec(topic: TopicPlan) -> TopicCodec:
    return TopicCodec(topic.msgtype, topic.fields, DISTRO, frame_id=topic.frame_id)


def _wait(condition: Callable[[], bool], what: str, nodes: list[subprocess.Popen[bytes]]) -> None:
    deadline = time.monotonic() + 120
    while not condition():
        if any(node.poll() is not None for node in nodes):
            msg = f"a node ended before {what}"
            raise RuntimeError(msg)
        if time.monotonic() > deadline:
            msg = f"timed out waiting for {what}"
            raise RuntimeError(msg)
        time.sleep(0.01)


@dataclass
class Setup:
    """What one measurement needs: the variant system, its plan, frame counts."""

    rate: float
    warmup: int
    frames: int
    tail: int
    #: Label of the DDS configuration (a key of :data:`DDS_CONFIGS`).
    dds: str = "default"

    @property
    def total_frames(self) -> int:
        """Frames published in the run."""
        return self.warmup + self.frames + self.tail

    @property
    def measured(self) -> range:
        """Indices of the frames whose answers count."""
        return range(self.warmup, self.warmup + self.frames)


class Simulator:
    """This script's side of the run, as the simulator node would do it: /clock, frames, /odom."""

    def __init__(self, participant: Participant, plan: Ros2Plan, run: RunSettings) -> None:
        image, odom = plan.topic("/camera/image_raw"), plan.topic("/odom")
        self.run = run
        self.image_codec, self.odom_codec = _codec(image), _codec(odom)
        self.camera = participant.writer(dds_topic(image.name), image.msgtype, image.qos)
        self.odom = participant.writer(dds_topic(odom.name), odom.msgtype, odom.qos)
        self.clock = participant.writer(CLOCK_DDS, CLOCK_TYPE, CONTROL_WRITER_QOS)
        self.ticks = StepClock(run, DISTRO)
        self.frames = {p: frame_with_board(p) for p in POSITIONS}
        self.pose = {"base_pos": np.array([0.0, 0.0, 0.05]),
                     "base_quat": np.array([1.0, 0.0, 0.0, 0.0])}  # fmt: skip
        #: Delay of each frame behind its real-time instant (s): did this process keep up?
        self.lags: list[float] = []

    def matched(self) -> bool:
        """Every node subscribed: camera (detector), odom (odometry), clock (all three)."""
        return (
            self.camera.matched() >= 1
            and self.odom.matched() >= 1
            and self.clock.matched() >= len(NODES)
        )

    def drive(self, rate: float) -> Answers:
        """Publish at real time until the stop time; returns when each frame was published."""
        step = self.run.step
        world, camera, odom = (round(p / step) for p in (WORLD_PERIOD, 1 / rate, ODOM_PERIOD))
        answers = Answers([], [])
        frame = 0
        start = time.perf_counter()
        for n in range(0, self.run.steps, world):
            target = start + n * step
            delay = target - time.perf_counter()
            if delay > 0:
                time.sleep(delay)
            t = self.run.time_at(n)
            if n + world > frame * camera:  # the tick below passes the detector's grid point
                position = POSITIONS[frame % len(POSITIONS)]
                frame += 1
                published = time.perf_counter()
                self.lags.append(published - target)
                self.camera.write(self.image_codec.encode({"front": self.frames[position]}, t))
                answers.published.append(published)
                answers.positions.append(position)
            if n % odom == 0:
                self.odom.write(self.odom_codec.encode(self.pose, t))
            self.clock.write(self.ticks.encode(min(n + world, self.run.steps)))
        return answers


# -- one measurement ----------------------------------------------------------------------------


@dataclass
class Outcome:
    """One camera rate's figures."""

    rate: float
    dds: str
    frames: int
    blob_ms: list[float]
    cmd_ms: list[float]
    detector_missed: int
    dropped: int
    lag_ms: float
    late: int
    node_exit_codes: dict[str, int | None]
    answers: Answers


def percentile(samples: Sequence[float], q: float) -> float:
    """The ``q`` quantile (nearest rank); NaN without samples."""
    if not samples:
        return math.nan
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, max(0, math.ceil(q * len(ordered)) - 1))]


def _stop(nodes: dict[str, subprocess.Popen[bytes]], timeout: float) -> dict[str, int | None]:
    deadline = time.monotonic() + timeout
    for node in nodes.values():
        try:
            node.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            node.kill()
            node.wait()
    return {name: node.returncode for name, node in nodes.items()}


def measure(setup: Setup, folder: Path) -> Outcome:
    """Start the three nodes on a variant system, drive them, match answers to frames."""
    camera_period = 1.0 / setup.rate
    provisional = variant_text(setup.rate, 1.0)
    path = folder / f"pipeline_{setup.rate:g}hz.yaml"
    path.write_text(provisional, encoding="utf-8")
    step = fmionnx.load(path).compiled.run.step
    stop = setup.total_frames * round(camera_period / step) * step
    path.write_text(variant_text(setup.rate, stop), encoding="utf-8")
    system = fmionnx.load(path).compiled
    plan = plan_for(system, DISTRO)
    tag = f"{setup.rate:g}hz_{list(DDS_CONFIGS).index(setup.dds)}"
    logs = {name: (folder / f"{name}_{tag}.log").open("wb") for name in NODES}
    nodes: dict[str, subprocess.Popen[bytes]] = {}
    participant = Participant(from_environment(DISTRO))
    cmd_topic, blob_topic = plan.topic("/cmd_vel"), plan.topic("/onnx_blobX")
    listeners = {
        topic.name: Listener(participant.reader(dds_topic(topic.name), topic.msgtype, topic.qos))
        for topic in (cmd_topic, blob_topic)
    }
    codes: dict[str, int | None] = {}
    try:
        simulator = Simulator(participant, plan, system.run)
        for name in NODES:
            nodes[name] = subprocess.Popen(
                [sys.executable, "-m", "fmionnx", "node", str(path), name, "--sync", "free",
                 "--ros-distro", DISTRO.value],
                stdout=logs[name], stderr=subprocess.STDOUT,
            )  # fmt: skip
        running = list(nodes.values())
        try:
            _wait(simulator.matched, "the nodes subscribed", running)
            _wait(lambda: all(lst.reader.matched() >= 1 for lst in listeners.values()),
                  "the nodes published", running)  # fmt: skip
        except RuntimeError as exc:
            for log in logs.values():
                log.flush()
            tails = {
                n: (folder / f"{n}_{tag}.log").read_text(errors="replace")[-800:] for n in NODES
            }
            msg = f"{exc}; node logs:\n" + "\n".join(f"[{n}] {t}" for n, t in tails.items())
            raise RuntimeError(msg) from None
        for listener in listeners.values():
            listener.start()
        answers = simulator.drive(setup.rate)
        codes = _stop(nodes, 60.0)
    finally:
        for listener in listeners.values():
            listener.stop.set()
            if listener.is_alive():
                listener.join()
        for node in nodes.values():
            if node.poll() is None:
                node.kill()
                node.wait()
        for log in logs.values():
            log.close()
        participant.close()
    cmd_codec, blob_codec = _codec(cmd_topic), _codec(blob_topic)
    commands = [
        (t, float(cmd_codec.decode(d)[0]["w"][0])) for t, d in listeners["/cmd_vel"].samples
    ]
    blobs = [
        (t, float(blob_codec.decode(d)[0]["blobX"][2])) for t, d in listeners["/onnx_blobX"].samples
    ]
    by_w = nearest_position({p: steering(p) for p in POSITIONS}, 1e-6)
    by_x = nearest_position({p: board_column(p) for p in POSITIONS}, 1e-3)
    answers.answered["/cmd_vel"] = match(answers.published, answers.positions, commands, by_w)
    answers.answered["/onnx_blobX"] = match(answers.published, answers.positions, blobs, by_x)
    frames = setup.measured
    return Outcome(
        rate=setup.rate,
        dds=setup.dds,
        frames=len(frames),
        blob_ms=answers.latencies_ms("/onnx_blobX", frames),
        cmd_ms=answers.latencies_ms("/cmd_vel", frames),
        detector_missed=answers.missing("/onnx_blobX", frames),
        dropped=answers.missing("/cmd_vel", frames),
        lag_ms=max((simulator.lags[k] for k in frames), default=0.0) * 1e3,
        late=sum(1 for k in frames if simulator.lags[k] > LATE),
        node_exit_codes=codes,
        answers=answers,
    )


def print_outcome(outcome: Outcome) -> None:
    """One table per camera rate."""
    print(f"camera {outcome.rate:g} Hz, DDS {outcome.dds}, {outcome.frames} frames measured; nodes "
          f"{', '.join(NODES)} (exit codes {list(outcome.node_exit_codes.values())}); "
          f"publisher lag max {outcome.lag_ms:.2f} ms")  # fmt: skip
    print(f"{'measurement':<44}{'p50':>10}{'p99':>10}{'max':>10}")
    for label, samples in (
        ("frame -> /onnx_blobX received (ms)", outcome.blob_ms),
        ("frame -> /cmd_vel received (ms)", outcome.cmd_ms),
    ):
        p50, p99 = percentile(samples, 0.5), percentile(samples, 0.99)
        print(f"{label:<44}{p50:>10.2f}{p99:>10.2f}{max(samples, default=math.nan):>10.2f}")
    print(f"{'frames published > 5 ms late (host load)':<44}{outcome.late:>10}")
    print(f"{'frames the detector never reported':<44}{outcome.detector_missed:>10}")
    print(f"{'dropped frames (no /cmd_vel answer)':<44}{outcome.dropped:>10}")


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """Options (defaults are what ``make bench`` runs)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--rates", type=float, nargs="+", default=[30.0, 10.0], help="camera Hz")
    parser.add_argument("--seconds", type=float, default=10.0, help="measured seconds per rate")
    parser.add_argument("--multicast-rates", type=float, nargs="*", default=[30.0],
                        help="camera Hz also measured with AllowMulticast=true")  # fmt: skip
    parser.add_argument("--warmup", type=float, default=2.0, help="seconds not measured, first")
    parser.add_argument("--domain", type=int, default=None,
                        help="first DDS domain id (one per configuration; default: random)")  # fmt: skip
    return parser.parse_args(argv)


@contextlib.contextmanager
def dds_environment(domain: int, config: str | None) -> Iterator[None]:
    """Loopback only, on ``domain``, with ``CYCLONEDDS_URI`` = ``config`` (for the nodes too).

    One domain per configuration: a process keeps one Cyclone configuration per domain.
    """
    saved = {
        k: os.environ.get(k) for k in ("ROS_DOMAIN_ID", "ROS_LOCALHOST_ONLY", "CYCLONEDDS_URI")
    }
    os.environ.update({"ROS_DOMAIN_ID": str(domain), "ROS_LOCALHOST_ONLY": "1"})
    os.environ.pop("CYCLONEDDS_URI", None)
    if config is not None:
        os.environ["CYCLONEDDS_URI"] = config
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def main(argv: Sequence[str] | None = None) -> list[Outcome]:
    """Measure every rate and configuration; print the tables."""
    args = parse(argv)
    runs = [(rate, "default") for rate in args.rates]
    runs += [(rate, "AllowMulticast=true") for rate in args.multicast_rates]
    domain = args.domain if args.domain is not None else random.SystemRandom().randint(100, 200)
    outcomes = []
    with tempfile.TemporaryDirectory(prefix="fmionnx-pipeline-") as tmp:
        for rate, dds in runs:
            setup = Setup(rate, round(args.warmup * rate), round(args.seconds * rate),
                          max(2, round(0.5 * rate)), dds)  # fmt: skip
            with dds_environment(domain + list(DDS_CONFIGS).index(dds), DDS_CONFIGS[dds]):
                outcome = measure(setup, Path(tmp))
            print_outcome(outcome)
            outcomes.append(outcome)
    return outcomes


if __name__ == "__main__":
    main()
