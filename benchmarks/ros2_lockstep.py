"""Lockstep step rate: the reference system as ROS 2 nodes against the in-process master.

Run: ``python benchmarks/ros2_lockstep.py`` (about a minute; domain chosen at random, traffic
kept on 127.0.0.1). Both runs are ``fmionnx run systems/sign_follower.yaml --stop-time S``
processes, one in-process, one ``--backend ros2 --sync lockstep``, alternated ``--repeat``
times. The step rate is base steps per second of loop wall time (``run.json``: ``steps`` over
``wall_time``, which both backends measure after set-up); the process wall time, start-up
included, is shown beside it. Each pair's ``results.csv`` must be byte-identical (the lockstep
guarantee), else the row says so.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SYSTEM = REPO / "systems" / "sign_follower.yaml"
INPROCESS = "in-process"
LOCKSTEP = "ros2 lockstep"
MODES: dict[str, tuple[str, ...]] = {
    INPROCESS: (),
    LOCKSTEP: ("--backend", "ros2", "--sync", "lockstep"),
}


@dataclass
class Samples:
    """Every run of one mode."""

    steps: list[int] = field(default_factory=list)
    loop_s: list[float] = field(default_factory=list)
    process_s: list[float] = field(default_factory=list)
    csv: list[bytes] = field(default_factory=list)

    @property
    def steps_per_s(self) -> float:
        """Median base steps per second of loop wall time."""
        return statistics.median(n / s for n, s in zip(self.steps, self.loop_s, strict=True))


def run_once(mode: str, stop: float, out: Path) -> tuple[int, float, float, bytes]:
    """One ``fmionnx run``: steps, loop wall (run.json), process wall, results.csv bytes."""
    argv = [sys.executable, "-m", "fmionnx", "run", str(SYSTEM), "-q", "--no-checks", "--stop-time", repr(stop),
            "--out", str(out), *MODES[mode]]  # fmt: skip
    started = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, timeout=600, check=False)
    process = time.perf_counter() - started
    if done.returncode != 0:
        msg = f"{mode} run failed (exit {done.returncode}):\n{done.stderr.strip()}"
        raise RuntimeError(msg)
    info = json.loads((out / "run.json").read_text(encoding="utf-8"))
    return int(info["steps"]), float(info["wall_time"]), process, (out / "results.csv").read_bytes()


def measure(stop: float, repeat: int) -> dict[str, Samples]:
    """Alternate the two modes ``repeat`` times (round r starts with the r-th mode)."""
    samples = {mode: Samples() for mode in MODES}
    order = list(MODES)
    with tempfile.TemporaryDirectory(prefix="fmionnx-lockstep-") as tmp:
        for r in range(repeat):
            for mode in order[r % 2 :] + order[: r % 2]:
                out = Path(tmp) / f"{mode.replace(' ', '_')}_{r}"
                steps, loop, process, csv = run_once(mode, stop, out)
                sample = samples[mode]
                sample.steps.append(steps)
                sample.loop_s.append(loop)
                sample.process_s.append(process)
                sample.csv.append(csv)
    return samples


def identical(samples: dict[str, Samples]) -> bool:
    """Every lockstep results.csv equals the in-process one of the same round."""
    pairs = zip(samples[INPROCESS].csv, samples[LOCKSTEP].csv, strict=True)
    return all(a == b for a, b in pairs)


def print_table(samples: dict[str, Samples], stop: float) -> None:
    """Steps/s of each mode and the ratio."""
    repeat = len(samples[INPROCESS].steps)
    base = samples[INPROCESS].steps_per_s
    print(f"{SYSTEM.name}, {stop:g} s simulated, median of {repeat} alternated runs")
    print(
        f"{'mode':<16}{'steps':>8}{'loop s':>10}{'steps/s':>10}{'x in-proc':>11}{'process s':>11}"
    )
    for mode, sample in samples.items():
        rate = sample.steps_per_s
        print(
            f"{mode:<16}{sample.steps[0]:>8}{statistics.median(sample.loop_s):>10.2f}"
            f"{rate:>10.0f}{rate / base:>11.2f}{statistics.median(sample.process_s):>11.2f}"
        )
    same = "yes" if identical(samples) else "NO"
    print(f"{'lockstep results.csv byte-identical to in-process':<55}{same:>10}")


def parse(argv: Sequence[str] | None) -> argparse.Namespace:
    """Options (defaults are what ``make bench`` runs)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--stop", type=float, default=8.0, help="simulated seconds per run")
    parser.add_argument("--repeat", type=int, default=3, help="runs of each mode")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> dict[str, Samples]:
    """Measure, print, return the samples."""
    args = parse(argv)
    os.environ.setdefault("ROS_DOMAIN_ID", str(random.SystemRandom().randint(100, 230)))
    os.environ["ROS_LOCALHOST_ONLY"] = "1"
    samples = measure(args.stop, args.repeat)
    print_table(samples, args.stop)
    return samples


if __name__ == "__main__":
    main()
