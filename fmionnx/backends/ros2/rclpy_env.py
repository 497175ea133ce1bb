"""Finding a usable rclpy: installed, loadable, which ROS 2 distribution, without crashing.

rclpy comes either from a sourced ROS 2 installation or from the PyPI wheels of the ``rclpy``
extra (Jazzy's rclpy 7.1 with Fast DDS), installed from the clone fmionnx is installed from
(``pip install -e '.[rclpy]'`` in its venv; ``make setup-test`` includes it: fmionnx is not
published on PyPI, so ``pip install 'fmionnx[rclpy]'`` cannot work). The wheels need
their shared libraries on ``LD_LIBRARY_PATH``; their ``ros-wheels-bootstrapper`` sets it and
re-executes the interpreter at start-up, so nothing is needed in the user's shell.

Two traps make loading rclpy worth a guard. A ``RMW_IMPLEMENTATION`` naming a middleware that
is not installed (``rmw_cyclonedds_cpp`` is a common setting; the wheels ship only
``rmw_fastrtps_cpp``) makes rcl call ``exit(102)`` while the library loads, so it is checked
before the import. A missing middleware library is an ``ImportError`` naming the file. Both
become :class:`RclpyUnavailableError` with what to do. :func:`rclpy_problem` checks in a child
process, for callers (the supervisor's command line, tests) that must not load rclpy and its
DDS into their own process.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType

from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.core.errors import FmionnxError

#: rclpy's major version per distribution (Humble 3.3, Iron 4/5, Jazzy 7.1, Kilted 9.1).
_RCLPY_MAJOR = {3: RosDistro.HUMBLE, 4: RosDistro.IRON, 5: RosDistro.IRON, 7: RosDistro.JAZZY,
                9: RosDistro.KILTED}  # fmt: skip
#: What to install when rclpy is missing: the project's extra (ROS 2 Jazzy wheels), from the
#: clone fmionnx is installed from, since fmionnx is not on PyPI.
INSTALL_HINT = (
    "in your clone of fmionnx run `.venv/bin/pip install -e '.[rclpy]'` (ROS 2 Jazzy wheels; "
    "`make setup-test` installs them too), or source a ROS 2 installation"
)


class RclpyUnavailableError(FmionnxError):
    """rclpy is not installed here or cannot load its middleware."""


def rclpy_distro() -> RosDistro | None:
    """The ROS 2 distribution of the rclpy found here (``ROS_DISTRO`` of a sourced install wins).

    None when it cannot be told (rclpy missing, or an unknown version).
    """
    named = os.environ.get("ROS_DISTRO", "").strip().lower()
    if named in {d.value for d in RosDistro}:
        return RosDistro(named)
    for dist in ("ros-rclpy", "rclpy"):
        try:
            major = int(importlib.metadata.version(dist).split(".")[0])
        except (importlib.metadata.PackageNotFoundError, ValueError):
            continue
        return _RCLPY_MAJOR.get(major)
    return None


def _library_dirs() -> list[Path]:
    dirs = [Path(p) for p in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep) if p]
    return [*dirs, Path(sys.prefix) / "lib"]


def _check_rmw_implementation() -> None:
    wanted = os.environ.get("RMW_IMPLEMENTATION", "").strip()
    if not wanted:
        return
    if any((folder / f"lib{wanted}.so").exists() for folder in _library_dirs()):
        return
    msg = (
        f"RMW_IMPLEMENTATION={wanted} names a ROS 2 middleware that is not installed here "
        "(rcl would end the process); unset it to use rclpy's default (rmw_fastrtps_cpp with "
        "the wheels) or install that middleware"
    )
    raise RclpyUnavailableError(msg)


def import_rclpy() -> ModuleType:
    """Import rclpy in this process, or raise :class:`RclpyUnavailableError` saying why not."""
    if importlib.util.find_spec("rclpy") is None:
        msg = f"rclpy is not installed for {sys.executable}: {INSTALL_HINT}"
        raise RclpyUnavailableError(msg)
    _check_rmw_implementation()
    try:
        return importlib.import_module("rclpy")
    except ImportError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        msg = f"rclpy is installed but cannot load ({first}); {INSTALL_HINT}"
        raise RclpyUnavailableError(msg) from None


def rclpy_problem(timeout: float = 60.0) -> str | None:
    """Why rclpy cannot run here, checked in a child process; None when it can."""
    if importlib.util.find_spec("rclpy") is None:
        return f"rclpy is not installed for {sys.executable}: {INSTALL_HINT}"
    code = (
        "import sys\n"
        "from fmionnx.backends.ros2.rclpy_env import RclpyUnavailableError, import_rclpy\n"
        "try:\n"
        "    import_rclpy()\n"
        "except RclpyUnavailableError as exc:\n"
        "    sys.exit(str(exc))\n"
    )
    try:
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout,
            check=False,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return f"importing rclpy took more than {timeout:g} s"
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    return lines[-1] if lines else f"importing rclpy failed (exit status {done.returncode})"


def distro_problem(distro: RosDistro) -> str | None:
    """Why ``--ros-distro distro`` does not fit the rclpy found here; None when it does.

    The distribution fixes the wire format of node discovery (a Humble ``Gid`` has 24 bytes,
    a Jazzy one 16), so rclpy nodes and the supervisor must agree with rclpy's own.
    """
    found = rclpy_distro()
    if found is None or found is distro:
        return None
    return f"the rclpy here is ROS 2 {found.value}: add `--ros-distro {found.value}`"
