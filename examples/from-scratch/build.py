"""Build the heating example's models into ``build/examples/from-scratch/``: two FMUs, one ONNX.

Why this script exists: a system file names built models, and built models are products, not
sources, so they never go into git. The FMUs are written the way the project's own models are
(``models/fmus``): each folder here holds a model description and the model's equations
(``sources/model.c``, ``sources/config.h``); the FMI 2 entry points come from the shared glue in
``models/fmus/common``. This script stages each folder plus that glue into a complete source
FMU (``src/<name>/``) and compiles it with ``fmionnx build-fmu`` — the command a user runs on
any source FMU. The ONNX feed-forward is trained by ``feedforward.py``.

Incremental like ``make models``: a product is rebuilt only when the hash of its inputs,
recorded next to it in ``<product>.stamp``, changed.

Usage: ``python examples/from-scratch/build.py [--out DIR] [--force]``.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import shutil
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
GLUE = [REPO / "models" / "fmus" / "common" / name for name in ("fmi2Functions.c", "model.h")]
FMUS = ("Heater", "PIController")
FEEDFORWARD = HERE / "feedforward.py"
DEFAULT_OUT = REPO / "build" / "examples" / "from-scratch"


def _digest(paths: Iterable[Path]) -> str:
    digest = hashlib.sha256()
    for path in paths:
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        for file in files:
            digest.update(file.relative_to(REPO).as_posix().encode())
            digest.update(file.read_bytes())
    return digest.hexdigest()


def _current(product: Path, digest: str) -> bool:
    stamp = product.with_name(product.name + ".stamp")
    return product.exists() and stamp.exists() and stamp.read_text() == digest


def _stamp(product: Path, digest: str) -> None:
    product.with_name(product.name + ".stamp").write_text(digest)


def build_fmu(name: str, out: Path, *, force: bool = False) -> str:
    """Stage ``fmus/<name>`` with the shared glue and compile it; one line of log."""
    product = out / f"{name}.fmu"
    digest = _digest([HERE / "fmus" / name, *GLUE])
    if not force and _current(product, digest):
        return f"{product}: up to date"
    staged = out / "src" / name
    shutil.rmtree(staged, ignore_errors=True)
    shutil.copytree(HERE / "fmus" / name, staged)
    for file in GLUE:
        shutil.copy2(file, staged / "sources" / file.name)
    # --force: the product is this script's (its stamp says so), also one built before
    # build-fmu marked what it writes.
    command = [sys.executable, "-m", "fmionnx", "build-fmu", str(staged), "-o", str(product)]
    command.append("--force")
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        msg = f"building {name} failed:\n{done.stdout}{done.stderr}"
        raise RuntimeError(msg)
    _stamp(product, digest)
    return f"{product}: built"


def build_feedforward(out: Path, *, force: bool = False) -> str:
    """Train and write ``feedforward.onnx`` when its script changed; one line of log."""
    product = out / "feedforward.onnx"
    digest = _digest([FEEDFORWARD])
    if not force and _current(product, digest):
        return f"{product}: up to date"
    spec = importlib.util.spec_from_file_location("feedforward", FEEDFORWARD)
    if spec is None or spec.loader is None:
        msg = f"cannot load {FEEDFORWARD}"
        raise ImportError(msg)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    error = module.write_model(product)
    _stamp(product, digest)
    return f"{product}: trained (largest error on the measurements {error:.0f} W)"


def build(out: Path = DEFAULT_OUT, *, force: bool = False) -> list[str]:
    """Build everything the heating system needs into ``out``; the log lines."""
    out.mkdir(parents=True, exist_ok=True)
    return [
        *(build_fmu(name, out, force=force) for name in FMUS),
        build_feedforward(out, force=force),
    ]


def main(argv: list[str] | None = None) -> int:
    """Command line: ``build.py [--out DIR] [--force]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--force", action="store_true", help="rebuild even when up to date")
    args = parser.parse_args(argv)
    try:
        print("\n".join(build(args.out, force=args.force)))
    except RuntimeError as exc:
        print(f"examples/from-scratch/build.py: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
