"""The machine a benchmark ran on: numbers without it cannot be compared."""

from __future__ import annotations

import os
import platform
import sys
from importlib import metadata
from pathlib import Path

#: Distributions whose versions decide the measured numbers.
PACKAGES = ("fmionnx", "fmpy", "numpy", "onnxruntime", "mujoco", "libcosimpy")


def cpu_model() -> str:
    """CPU model from /proc/cpuinfo (Linux), else what ``platform`` knows."""
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text(encoding="utf-8", errors="replace").splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def usable_cores() -> int:
    """Cores this process may run on (the affinity mask, not the host's count)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def versions() -> dict[str, str]:
    """Installed versions of :data:`PACKAGES` (``missing`` when not installed)."""
    found = {}
    for name in PACKAGES:
        try:
            found[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            found[name] = "missing"
    return found


def describe() -> dict[str, object]:
    """CPU, cores, OS, Python and package versions, as one JSON-ready mapping."""
    return {
        "cpu": cpu_model(),
        "cores": usable_cores(),
        "os": f"{platform.system()} {platform.release()}",
        "python": f"{platform.python_implementation()} {sys.version.split()[0]}",
        "mujoco_gl": os.environ.get("MUJOCO_GL", ""),
        "packages": versions(),
    }


def headline(title: str, info: dict[str, object]) -> str:
    """A benchmark's first line: its title in bold, then the machine it ran on."""
    return f"[bold]{title}[/bold]  {info['cpu']}, {info['cores']} cores, {info['python']}, {info['os']}"
