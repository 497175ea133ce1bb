"""Pack ``vendor/`` and the heating FMUs into ``build/examples/ssp-roundtrip/heating.ssp``.

Why: the example starts from an SSP "as another tool wrote it". The archive's text parts (the
SSD in OMSimulator's style, one ``.ssv`` per component) are kept readable in ``vendor/``; the
FMUs are build products (``examples/from-scratch/build.py`` compiles them from C), so the
archive is assembled here, never committed. FMUs go in under the names the SSD gives them
(``resources/0001_room.fmu``, OMSimulator's numbering). Members are written in a fixed order
with a fixed date, so the same inputs give the same archive bytes.

Usage: ``python examples/ssp-roundtrip/pack.py [--out FILE]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
VENDOR = HERE / "vendor"
BUILD_SCRIPT = HERE.parent / "from-scratch" / "build.py"
FMU_BUILD = HERE.parent.parent / "build" / "examples" / "from-scratch"
#: Archive member -> FMU built by the from-scratch example.
FMUS = {
    "resources/0001_room.fmu": "Heater.fmu",
    "resources/0002_controller.fmu": "PIController.fmu",
}
DEFAULT_OUT = Path("build/examples/ssp-roundtrip/heating.ssp")


def _build_fmus() -> None:
    """Compile the FMUs (or find them up to date) with the from-scratch example's script."""
    spec = importlib.util.spec_from_file_location("from_scratch_build", BUILD_SCRIPT)
    if spec is None or spec.loader is None:
        msg = f"cannot load {BUILD_SCRIPT}"
        raise ImportError(msg)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.build(FMU_BUILD)


def _add(archive: zipfile.ZipFile, name: str, data: bytes) -> None:
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    archive.writestr(info, data)


def pack(out: Path) -> Path:
    """Write the archive to ``out`` (through a temporary name) and return it."""
    _build_fmus()
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.name + ".partial")
    with zipfile.ZipFile(partial, "w") as archive:
        for file in sorted(p for p in VENDOR.rglob("*") if p.is_file()):
            _add(archive, file.relative_to(VENDOR).as_posix(), file.read_bytes())
        for member, built in FMUS.items():
            _add(archive, member, (FMU_BUILD / built).read_bytes())
    partial.replace(out)
    return out


def main(argv: list[str] | None = None) -> int:
    """Command line: ``pack.py [--out FILE]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    print(f"wrote {pack(args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
