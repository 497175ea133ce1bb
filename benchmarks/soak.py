"""Soak test: the reference scenario for one simulated hour, watching memory, files, threads.

A leak that costs a few kilobytes per second is invisible in a 32 s run and fatal in a study
of many long runs. This script runs ``systems/sign_follower.yaml`` in-process through the
Python API (``fmionnx.load`` with another stop time, as :mod:`benchmarks.scenario` does) for
``--stop-time`` simulated seconds (default 3600; ``--minutes-simulated`` shortens it), while
a background thread samples every ``--sample-every`` wall seconds:

* **RSS** (``/proc/self/statm``: resident pages times the page size),
* **open file descriptors** (entries of ``/proc/self/fd``),
* **threads** (``threading.active_count()`` for Python threads, ``Threads:`` of
  ``/proc/self/status`` for all of them: onnxruntime's and MuJoCo's native threads too),
* the simulated time reached (from the run's progress callback).

The robot reaches B at about 28 s and then stands still; the scenario keeps every component
stepping (physics, camera, detector, FMUs), so the rest of the hour is the steady state a
leak would show in.

**What growth is expected.** The recorder keeps every recorded signal in memory by design:
each component appends one row per step of its own (:mod:`fmionnx.runtime.recorder`; the
world steps every base step, so its seven recorded columns take a row per 2 ms), in arrays
that reserve 65 536 rows and then grow by doubling, and when the run ends the rows are
expanded to the base-step grid (1.8 M rows for an hour) for the results. So RSS grows with
simulated time even without a leak: by the recorder's arrays during the loop (about 100 MB in
an hour, more while an array is copied to its doubled size), and by the results table at the
end. The script computes the recorder's resident bytes from the recorded columns and each
component's steps (8 bytes x rows x columns: rows written while in the first reservation,
every allocated row once an array has grown) and reports the RSS growth between the end of
warm-up (``--warmup``, 10 % of the run by default: GL contexts, the ONNX session and the
first allocations are made by then) and the end of the loop, both in total and *excluding*
the recorder's own growth. Target: growth excluding the recorder at most 5 %, and no growth
of file descriptors or threads. The results table is reported apart (RSS after ``run``
returns, and the table's size computed the same way).

Targets are reported, not asserted. Writes ``build/bench/soak.json``. ``make soak`` runs the
full hour, which takes as long as the real-time factor says (about 22 minutes at 2.7x real
time on 2 cores); ``--minutes-simulated 2`` checks the script in under a minute.
"""

from __future__ import annotations

import argparse
import datetime as dt
import gc
import json
import os
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # run as a script: make `benchmarks` importable

os.environ.setdefault("MUJOCO_GL", "egl")  # as the other benchmarks do; set before mujoco loads

from rich.console import Console  # noqa: E402

from benchmarks import machine, report, scenario  # noqa: E402

DEFAULT_OUT = REPO / "build" / "bench" / "soak.json"
#: Rows a recorder track reserves before growing (``fmionnx.runtime.recorder.CHUNK_ROWS``).
CHUNK_ROWS = 1 << 16
#: Bytes of one recorded value (float64).
VALUE_BYTES = 8
#: RSS growth excluding the recorder, in percent of the warm RSS.
RSS_TARGET_PERCENT = 5.0
PAGE_BYTES = os.sysconf("SC_PAGE_SIZE")


@dataclass
class Sample:
    """One observation of the process; ``phase``: ``before`` the run, in the ``loop``,
    ``after run`` (results table built, models terminated), ``after free`` (results freed)."""

    phase: str
    wall_s: float
    simulated_s: float
    rss_bytes: int
    fds: int
    python_threads: int
    os_threads: int


def rss_bytes() -> int:
    """Resident set size of this process (second field of ``/proc/self/statm``, in pages)."""
    fields = Path("/proc/self/statm").read_text(encoding="ascii").split()
    return int(fields[1]) * PAGE_BYTES


def open_fds() -> int:
    """Open file descriptors of this process (the listing's own descriptor included)."""
    return sum(1 for _ in Path("/proc/self/fd").iterdir())


def os_threads() -> int:
    """Threads of this process as the kernel counts them (Python and native ones)."""
    for line in Path("/proc/self/status").read_text(encoding="ascii").splitlines():
        if line.startswith("Threads:"):
            return int(line.split()[1])
    return 0


class Sampler(threading.Thread):
    """Samples the process every ``every`` seconds until stopped (a daemon: it never keeps
    the process alive). The progress callback feeds it the simulated time."""

    def __init__(self, every: float) -> None:
        super().__init__(name="soak-sampler", daemon=True)
        self.every = every
        self.samples: list[Sample] = []
        self.simulated = 0.0
        self.started = time.perf_counter()
        self._halt = threading.Event()

    def progress(self, _done: int, _total: int, simulated: float) -> None:
        """``RunOptions.progress``: remember how far the run is."""
        self.simulated = simulated

    def sample(self, phase: str = "loop") -> Sample:
        """Take one sample now (also called from the main thread around the run)."""
        taken = Sample(
            phase,
            time.perf_counter() - self.started,
            self.simulated,
            rss_bytes(),
            open_fds(),
            threading.active_count(),
            os_threads(),
        )
        self.samples.append(taken)
        return taken

    def run(self) -> None:
        """Sample until :meth:`stop`."""
        while not self._halt.wait(self.every):
            self.sample()

    def stop(self) -> None:
        """End the sampling (the thread ends within one interval)."""
        self._halt.set()
        self.join()


@dataclass
class RecorderModel:
    """How many bytes the recorder holds after a given number of base steps.

    ``columns``: recorded columns per component; ``period_steps``: each component's period in
    base steps; ``total_steps``: base steps of the run (a track's capacity depends on it).
    """

    columns: dict[str, int]
    period_steps: dict[str, int]
    total_steps: int
    notes: list[str] = field(default_factory=list)

    def resident_bytes(self, steps_done: int) -> int:
        """Bytes of the recorder's arrays in RSS after ``steps_done`` base steps.

        A track reserves ``min(capacity, CHUNK_ROWS)`` rows with ``np.zeros`` (pages that
        become resident only as rows are written), and grows by ``np.concatenate`` (which
        writes the whole new array: resident at once), doubling as
        :class:`fmionnx.runtime.recorder.Track` does.
        """
        total = 0
        for name, count in self.columns.items():
            period = self.period_steps[name]
            capacity = self.total_steps // period + 2
            rows = 1 + steps_done // period  # the row at the start time, then one per step
            allocated = min(capacity, CHUNK_ROWS)
            grown = False
            while allocated < rows:
                allocated += max(min(max(allocated, CHUNK_ROWS), capacity - allocated), 1)
                grown = True
            total += (allocated if grown else rows) * count * VALUE_BYTES
        return total

    def table_bytes(self, steps_done: int) -> int:
        """Bytes of the results table on the base-step grid (every column and the time)."""
        return (steps_done + 1) * (sum(self.columns.values()) + 1) * VALUE_BYTES


def recorder_model(system: Any, signals: list[str]) -> RecorderModel:
    """The recorder's layout for the recorded ``signals`` (``component.port[i]`` names)."""
    compiled = system.compiled
    names = sorted((c.name for c in compiled.components), key=len, reverse=True)
    columns: dict[str, int] = {}
    for signal in signals:
        owner = next((n for n in names if signal.startswith(n + ".")), None)
        if owner is not None:
            columns[owner] = columns.get(owner, 0) + 1
    periods = {c.name: int(c.period_steps) for c in compiled.components}
    return RecorderModel(columns, periods, int(compiled.run.steps))


def first_at_or_after(samples: list[Sample], simulated: float) -> Sample:
    """The first sample at or after ``simulated`` seconds (the last one if none is)."""
    return next((s for s in samples if s.simulated_s >= simulated), samples[-1])


def percent(part: float, whole: float) -> float:
    """``part`` as a percentage of ``whole``."""
    return 100.0 * part / whole if whole else float("nan")


def soak(stop_time: float, every: float, warmup: float) -> dict[str, Any]:
    """Run the scenario to ``stop_time`` while sampling; returns the JSON document."""
    system = scenario.load_system(stop_time=stop_time)
    sampler = Sampler(every)
    from fmionnx.runtime.result import RunOptions

    before = sampler.sample("before")
    sampler.start()
    started = time.perf_counter()
    result = system.run(options=RunOptions(progress=sampler.progress))
    wall = time.perf_counter() - started
    sampler.stop()
    # Samples of the stepping loop only: once the simulated time reaches the stop time the
    # run builds its results table (hundreds of MB for an hour) and frees the models, which a
    # sample may still see in the "loop" phase; the table is reported apart ("after run").
    in_loop = [s for s in sampler.samples if s.phase == "loop" and 0.0 < s.simulated_s < stop_time]
    after_run = sampler.sample("after run")  # the results table is in memory now
    signals = list(result.signals)
    steps_done = int(result.steps_done)
    loop_wall = float(result.wall_time)
    del result
    gc.collect()
    after_free = sampler.sample("after free")

    model = recorder_model(system, signals)
    step = float(system.compiled.run.step)
    if not in_loop:
        msg = "no sample fell inside the loop: shorten --sample-every"
        raise SystemExit(msg)
    warm = first_at_or_after(in_loop, warmup * stop_time)
    end = in_loop[-1]
    recorder_warm = model.resident_bytes(round(warm.simulated_s / step))
    recorder_end = model.resident_bytes(round(end.simulated_s / step))
    growth = end.rss_bytes - warm.rss_bytes
    recorder_growth = recorder_end - recorder_warm
    excluding = growth - recorder_growth
    excluding_percent = percent(excluding, warm.rss_bytes)
    summary: dict[str, Any] = {
        "simulated_s": stop_time,
        "steps": steps_done,
        "wall_s": wall,
        "loop_wall_s": loop_wall,
        "real_time_factor": stop_time / wall if wall else None,
        "loop_real_time_factor": stop_time / loop_wall if loop_wall else None,
        "warmup_simulated_s": warm.simulated_s,
        "end_simulated_s": end.simulated_s,
        "rss_before_mb": before.rss_bytes / 1e6,
        "rss_warm_mb": warm.rss_bytes / 1e6,
        "rss_end_mb": end.rss_bytes / 1e6,
        "rss_peak_mb": max(s.rss_bytes for s in sampler.samples) / 1e6,
        "rss_after_run_mb": after_run.rss_bytes / 1e6,
        "rss_after_free_mb": after_free.rss_bytes / 1e6,
        "rss_growth_mb": growth / 1e6,
        "rss_growth_percent": percent(growth, warm.rss_bytes),
        "recorder_warm_mb": recorder_warm / 1e6,
        "recorder_end_mb": recorder_end / 1e6,
        "recorder_growth_mb": recorder_growth / 1e6,
        "rss_growth_excluding_recorder_mb": excluding / 1e6,
        "rss_growth_excluding_recorder_percent": excluding_percent,
        "results_table_mb": model.table_bytes(steps_done) / 1e6,
        "recorded_columns": model.columns,
        "fds_warm": warm.fds,
        "fds_end": end.fds,
        "fds_after_run": after_run.fds,
        "python_threads_warm": warm.python_threads,
        "python_threads_end": end.python_threads,
        "os_threads_warm": warm.os_threads,
        "os_threads_end": end.os_threads,
    }
    targets = [
        {
            "target": "RSS growth excluding the recorder (warm -> end)",
            "value": excluding_percent,
            "limit": f"<= {RSS_TARGET_PERCENT:g} %",
            "met": excluding_percent <= RSS_TARGET_PERCENT,
        },
        {
            "target": "open file descriptors (warm -> end)",
            "value": end.fds - warm.fds,
            "limit": "no growth",
            "met": end.fds <= warm.fds,
        },
        {
            "target": "threads, kernel count (warm -> end)",
            "value": end.os_threads - warm.os_threads,
            "limit": "no growth",
            "met": end.os_threads <= warm.os_threads,
        },
    ]
    return {
        "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "machine": machine.describe(),
        "system": str(scenario.SYSTEM.relative_to(REPO)),
        "summary": summary,
        "targets": targets,
        "samples": [
            {**asdict(s), "recorder_bytes": model.resident_bytes(round(s.simulated_s / step))}
            for s in sampler.samples
        ],
    }


SAMPLE_COLUMNS = (
    ("phase", "phase"),
    ("wall_s", "wall s"),
    ("simulated_s", "simulated s"),
    ("rss_mb", "RSS MB"),
    ("recorder_mb", "recorder MB (resident, model)"),
    ("fds", "fds"),
    ("python_threads", "Python threads"),
    ("os_threads", "threads"),
)
SUMMARY_COLUMNS = (("what", "what"), ("value", "value"))
TARGET_COLUMNS = (("target", "target"), ("value", "measured"), ("limit", "goal"), ("met", "met"))


def print_report(console: Console, document: dict[str, Any], rows: int = 12) -> None:
    """The samples (thinned to ``rows``), the summary and the targets."""
    summary = document["summary"]
    samples = document["samples"]
    loop = [s for s in samples if s["phase"] == "loop"]
    stride = max(1, len(loop) // rows)
    shown = [s for s in samples if s["phase"] == "before"]
    shown += loop[::stride] + ([loop[-1]] if loop and (len(loop) - 1) % stride else [])
    shown += [s for s in samples if s["phase"] in {"after run", "after free"}]
    report.print_table(
        console,
        f"Soak: {document['system']}, {summary['simulated_s']:g} s simulated",
        SAMPLE_COLUMNS,
        [
            {
                "phase": s["phase"],
                "wall_s": round(s["wall_s"], 1),
                "simulated_s": round(s["simulated_s"], 1),
                "rss_mb": round(s["rss_bytes"] / 1e6, 1),
                "recorder_mb": round(s["recorder_bytes"] / 1e6, 1),
                "fds": s["fds"],
                "python_threads": s["python_threads"],
                "os_threads": s["os_threads"],
            }
            for s in shown
        ],
    )
    keys = (
        "wall_s",
        "real_time_factor",
        "loop_wall_s",
        "loop_real_time_factor",
        "rss_warm_mb",
        "rss_end_mb",
        "rss_growth_mb",
        "rss_growth_percent",
        "recorder_growth_mb",
        "rss_growth_excluding_recorder_mb",
        "rss_growth_excluding_recorder_percent",
        "rss_peak_mb",
        "rss_after_run_mb",
        "results_table_mb",
        "rss_after_free_mb",
        "fds_warm",
        "fds_end",
        "os_threads_warm",
        "os_threads_end",
        "python_threads_warm",
        "python_threads_end",
    )
    report.print_table(
        console,
        "Summary (warm = first sample after the warm-up; end = last sample in the loop)",
        SUMMARY_COLUMNS,
        [{"what": k, "value": _round(summary[k])} for k in keys],
    )
    report.print_table(
        console, "Targets (reported, not asserted)", TARGET_COLUMNS, document["targets"]
    )


def _round(value: Any) -> Any:
    return round(value, 3) if isinstance(value, float) else value


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Command-line options."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop-time", type=float, default=3600.0, help="simulated seconds")
    parser.add_argument(
        "--minutes-simulated",
        type=float,
        default=None,
        help="simulated minutes (overrides --stop-time; e.g. 2 for a check of the script)",
    )
    parser.add_argument(
        "--sample-every", type=float, default=5.0, help="wall seconds between samples"
    )
    parser.add_argument(
        "--warmup",
        type=float,
        default=0.1,
        help="fraction of the run after which RSS counts as warm (default 0.1)",
    )
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON output")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the soak, print the tables, write the JSON; returns the JSON document."""
    args = parse(argv)
    stop = args.minutes_simulated * 60.0 if args.minutes_simulated is not None else args.stop_time
    console = Console(width=None if sys.stdout.isatty() else 150)
    if missing := scenario.missing_models():
        console.print(f"run `make models` first; missing {missing}")
        raise SystemExit(2)
    document = soak(stop, args.sample_every, args.warmup)
    print_report(console, document)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(document, indent=2, allow_nan=False, default=str)
    args.out.write_text(text + "\n", encoding="utf-8")
    console.print(
        f"\nwrote {args.out.relative_to(REPO) if args.out.is_relative_to(REPO) else args.out}"
    )
    return document


if __name__ == "__main__":
    main()
