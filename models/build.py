"""Build the reference models from source (``make models``): the FMUs and the ONNX detector.

Incremental: each product records a hash of everything it is built from in a ``.stamp`` file
next to it and is rebuilt only when that hash changes or the product is missing, so ``make
test`` costs nothing when the models are current.

The FMUs share the FMI glue in ``models/fmus/common`` (``fmi2Functions.c``, ``fmi3Functions.c``
and the model contract ``model.h``). Each model folder is a source FMU minus that glue; the build
stages ``<model>/`` plus the glue of its FMI version into one complete source FMU
(``<out>/src/<model>/``, a valid input of ``fmionnx build-fmu`` on its own) and compiles it.
A variant folder (``MODEL_SOURCES``, e.g. ``ReadOdometry3``, the FMI 3.0 build) holds only its
model description and build description and takes ``sources/`` from the model it builds, so
the equations exist once.
The MuJoCo scene needs no build: system files refer to ``models/world`` directly.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import re
import shutil
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from xml.etree import ElementTree

HERE = Path(__file__).resolve().parent
FMU_SOURCES = HERE / "fmus"
COMMON = FMU_SOURCES / "common"
FMU_NAMES = ("ReadOdometry", "SignTrackingLogic", "ReadOdometry3", "SignTrackingLogic3")
# Variant folder -> model folder whose sources/ (model.c, config.h) it is built from.
MODEL_SOURCES = {"ReadOdometry3": "ReadOdometry", "SignTrackingLogic3": "SignTrackingLogic"}
DETECTOR_SCRIPT = HERE / "onnx" / "build_sign_detector.py"


def _files(paths: Iterable[Path]) -> list[Path]:
    found: list[Path] = []
    for path in paths:
        found.extend(sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path])
    return found


def _digest(paths: Iterable[Path]) -> str:
    digest = hashlib.sha256()
    for file in _files(paths):
        digest.update(file.relative_to(HERE).as_posix().encode())
        digest.update(file.read_bytes())
    return digest.hexdigest()


def _up_to_date(product: Path, digest: str) -> bool:
    stamp = product.with_name(product.name + ".stamp")
    return product.exists() and stamp.exists() and stamp.read_text() == digest


def _record(product: Path, digest: str) -> None:
    product.with_name(product.name + ".stamp").write_text(digest)


def _fmi_major(name: str) -> str:
    """``"2"`` or ``"3"``: the FMI version the model folder ``name`` declares."""
    root = ElementTree.parse(FMU_SOURCES / name / "modelDescription.xml").getroot()
    return root.get("fmiVersion", "2.0").split(".")[0]


def _glue(name: str) -> list[Path]:
    """The shared files ``name`` is built with: ``model.h`` and the glue of its FMI version only,
    so that a new glue for another version neither ships in nor rebuilds the existing FMUs."""
    major = _fmi_major(name)
    return [
        file
        for file in _files([COMMON])
        if not re.match(r"fmi\d", file.name) or file.name.startswith(f"fmi{major}")
    ]


def _inputs(name: str) -> list[Path]:
    """Everything the FMU ``name`` is built from (its digest covers these)."""
    base = MODEL_SOURCES.get(name)
    own = [FMU_SOURCES / name]
    return (own if base is None else [FMU_SOURCES / base / "sources", *own]) + _glue(name)


def stage_fmu(name: str, staging: Path) -> Path:
    """Assemble the complete source FMU of ``name`` (model folder + shared glue) in ``staging``."""
    target = staging / name
    shutil.rmtree(target, ignore_errors=True)
    base = MODEL_SOURCES.get(name)
    if base is not None:
        shutil.copytree(FMU_SOURCES / base / "sources", target / "sources")
    shutil.copytree(FMU_SOURCES / name, target, dirs_exist_ok=True)
    for file in _glue(name):
        shutil.copy2(file, target / "sources" / file.name)
    return target


def build_fmus(out: Path, *, force: bool) -> list[str]:
    """Build every FMU that is out of date; return a line of log per FMU."""
    from fmionnx.kinds.fmu.build import build_fmu

    log = []
    for name in FMU_NAMES:
        product = out / f"{name}.fmu"
        digest = _digest(_inputs(name))
        if not force and _up_to_date(product, digest):
            log.append(f"{product}: up to date")
            continue
        build_fmu(stage_fmu(name, out / "src"), product)
        _record(product, digest)
        log.append(f"{product}: built")
    return log


def _load_detector_builder() -> Callable[[Path], Path]:
    spec = importlib.util.spec_from_file_location("build_sign_detector", DETECTOR_SCRIPT)
    if spec is None or spec.loader is None:
        msg = f"cannot load {DETECTOR_SCRIPT}"
        raise ImportError(msg)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    builder: Callable[[Path], Path] = module.write_model
    return builder


def build_detector(out: Path, *, force: bool) -> str:
    """Write ``sign_detector.onnx`` when its builder script changed."""
    product = out / "sign_detector.onnx"
    digest = _digest([DETECTOR_SCRIPT])
    if not force and _up_to_date(product, digest):
        return f"{product}: up to date"
    _load_detector_builder()(product)
    _record(product, digest)
    return f"{product}: built"


def main(argv: list[str] | None = None) -> int:
    """Command line: ``build.py --out build/models [--force]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("build/models"))
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    from fmionnx.core.errors import FmionnxError

    try:
        lines = [*build_fmus(out, force=args.force), build_detector(out, force=args.force)]
    except FmionnxError as exc:
        print(f"models/build.py: {exc}", file=sys.stderr)
        log = getattr(exc, "log", "")
        if log:
            print(log, file=sys.stderr)
        return 1
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
