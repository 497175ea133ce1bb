"""Runs of the Probe test FMU (tests/fixtures/fmus/Probe, built from C), and what they left.

The probe tries, once, what a hostile model would -- read a file, list a folder, connect to a
UNIX socket, fork -- and puts the outcome into its output ``y``: a count when it got through,
minus the errno when it was refused. Every process it starts carries a token in its
environment, so a test finds any that outlived the run (and ends them, after failing).
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import uuid
from dataclasses import dataclass
from pathlib import Path

from fmionnx.results.csvfile import read_csv

READ, READ_OWN, LIST, UNIX_CONNECT, ABSTRACT_CONNECT = 1, 2, 3, 4, 5
FORK, FORK_ESCAPE, FORK_THEN_CRASH = 6, 7, 8
#: A refused read, listing or connection (Landlock, seccomp).
REFUSED = -float(errno.EACCES)
#: A refused fork.
NO_PROCESS = -float(errno.EPERM)
#: Seconds a probe run may take; a run that hangs on a model's children fails here.
RUN_TIMEOUT = 60


@dataclass(frozen=True)
class ProbeRun:
    """How a run of ``fmionnx run`` ended, with each probe's ``y`` at the end."""

    code: int
    output: str
    outcomes: dict[str, float]


def system(folder: Path, probe: Path, probes: dict[str, str], *, extra: str = "") -> Path:
    """A system file in ``folder`` with one probe component per entry (name: its
    ``parameters`` in YAML flow style), recording each one's ``y``; ``extra``: more
    components (YAML lines)."""
    components = "".join(
        f"  {name}: {{kind: fmu, path: {probe}, parameters: {parameters}}}\n"
        for name, parameters in probes.items()
    )
    records = ", ".join(f"{name}.y" for name in probes)
    text = (
        f"fmionnx: 1\nname: probes\nrecord: [{records}]\nrun: {{stop: 0.05, step: 0.01}}\n"
        f"components:\n{components}{extra}"
    )
    path = folder / "probes.yaml"
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def run(
    system_file: Path, out: Path, *extra: str, env: dict[str, str], cwd: Path | None = None
) -> ProbeRun:
    """``fmionnx run SYSTEM --out OUT EXTRA...`` in a child with ``env`` added."""
    code = "import sys; from fmionnx.cli import main; sys.argv[0] = 'fmionnx'; main()"
    done = subprocess.run(
        [sys.executable, "-c", code, "run", str(system_file), "--out", str(out), "-q", *extra],
        capture_output=True,
        text=True,
        env=dict(os.environ, COLUMNS="300", **env),
        timeout=RUN_TIMEOUT,
        check=False,
        cwd=cwd,
    )
    outcomes: dict[str, float] = {}
    results = out / "results.csv"
    if results.exists():
        table = read_csv(results)
        outcomes = {
            name.removesuffix(".y"): float(values[-1])
            for name, values in table.items()
            if name.endswith(".y")
        }
    return ProbeRun(done.returncode, done.stdout + done.stderr, outcomes)


class Token:
    """A mark in the environment of every process a probe starts; finds and ends them."""

    VARIABLE = "FMIONNX_PROBE_TOKEN"

    def __init__(self) -> None:
        self.value = uuid.uuid4().hex
        self._entry = f"{self.VARIABLE}={self.value}".encode()

    @property
    def env(self) -> dict[str, str]:
        return {self.VARIABLE: self.value}

    def processes(self) -> list[int]:
        """Processes whose environment holds the token (the run's own and its models')."""
        found = []
        for entry in Path("/proc").iterdir():
            name = entry.name
            if not name.isdigit():
                continue
            try:
                environment = Path(f"/proc/{name}/environ").read_bytes()
            except OSError:
                continue
            if self._entry in environment.split(b"\0"):
                found.append(int(name))
        return found

    def end_all(self) -> None:
        """Kill what is left (after a failure: the suite must not keep them)."""
        for pid in self.processes():
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                continue
