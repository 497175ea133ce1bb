"""The CLI starts without the simulation libraries: ``--help`` and ``validate`` load no numpy,
fmpy, onnxruntime or MuJoCo at import time (they load when a model is read or a system runs)."""

from __future__ import annotations

import subprocess
import sys


def test_importing_the_cli_loads_no_simulation_library() -> None:
    code = (
        "import sys, fmionnx.cli\n"
        "heavy = [m for m in ('numpy', 'fmpy', 'onnxruntime', 'mujoco') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == ""
