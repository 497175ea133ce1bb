"""Compile source-code FMUs into binary FMUs for this platform (``fmionnx build-fmu``).

This answers the paper's pain that FMUs exported on Windows did not run on Linux: any FMU that
ships its C sources (FMI 2 ``<SourceFiles>`` or FMI 3 / 2.0.4 ``buildDescription.xml``) is
compiled here with cmake and the system C compiler, through ``fmpy.build``. The compiler runs in
a child process so its output is captured and shown only when the build fails.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from fmionnx.core.archive import safe_extract, write_deterministic_zip
from fmionnx.core.errors import BuildError, ModelError
from fmionnx.core.scratch import scratch
from fmionnx.kinds.fmu.buildcheck import check_build_inputs

_BUILD_SCRIPT = (
    "import sys\n"
    "from fmpy.build import build_platform_binary\n"
    "build_platform_binary(sys.argv[1], build_dir=sys.argv[2])\n"
)


def default_output(source: Path) -> Path:
    """``Model/`` -> ``Model.fmu`` beside it; ``Model.fmu`` -> ``Model.built.fmu``."""
    if source.suffix == ".fmu":
        return source.with_name(source.stem + ".built.fmu")
    return source.with_name(source.name + ".fmu")


def build_fmu(source: Path, output: Path | None = None) -> Path:
    """Build the source FMU at ``source`` (folder or ``.fmu``) into ``output``; return it.

    Raises ModelError for an unusable source (missing model description or sources) and
    BuildError, with the compiler log, when compilation fails. ``output`` is written
    atomically: a failed build leaves no half-written FMU.
    """
    output = output or default_output(source)
    with scratch("build") as tmp:
        unpacked = tmp / "fmu"
        if source.is_dir():
            shutil.copytree(source, unpacked)
        elif source.is_file():
            safe_extract(source, unpacked)
        else:
            msg = f"`{source}` does not exist"
            raise ModelError("E010", msg)
        if not (unpacked / "modelDescription.xml").is_file():
            msg = f"`{source}` has no modelDescription.xml"
            raise ModelError(
                "E012", msg, hint="a source FMU holds modelDescription.xml and sources/"
            )
        if not (unpacked / "sources").is_dir():
            msg = f"`{source}` has no sources/ folder: there is nothing to compile"
            raise ModelError("E015", msg)
        check_build_inputs(unpacked)
        shutil.rmtree(unpacked / "binaries", ignore_errors=True)
        (tmp / "cmake").mkdir()  # fmpy writes CMakeCache.txt into it before cmake runs
        result = subprocess.run(
            [sys.executable, "-c", _BUILD_SCRIPT, str(unpacked), str(tmp / "cmake")],
            capture_output=True,
            text=True,
            check=False,
        )
        if result.returncode != 0:
            log = (result.stdout + result.stderr)[-8000:]
            msg = f"building `{source}` failed (exit {result.returncode})"
            raise BuildError(msg, log)
        write_deterministic_zip(unpacked, output)
    return output
