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
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == ""


def test_version_comes_from_the_package_metadata_without_simulation_libraries() -> None:
    from importlib.metadata import version

    import fmionnx

    code = (
        "import sys\n"
        "sys.argv = ['fmionnx', '--version']\n"
        "from fmionnx.cli import main\n"
        "try:\n"
        "    main()\n"
        "except SystemExit as exc:\n"
        "    code = exc.code\n"
        "heavy = [m for m in ('numpy', 'fmpy', 'onnxruntime', 'mujoco') if m in sys.modules]\n"
        "print(f'exit={code} heavy={\",\".join(heavy)}', file=sys.stderr)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout == f"fmionnx {version('fmionnx')}\n"
    assert done.stderr.strip() == "exit=0 heavy="
    assert version("fmionnx") == fmionnx.__version__  # pyproject.toml and the package agree
