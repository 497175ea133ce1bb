"""How fast is ``fmionnx validate`` on a large system? Target: under 2 s on 2 cores.

Generates, in a temporary folder, a system of 200 components and 2 000 connections built from
two real models used many times: the ``Gain`` test FMU (compiled from
``tests/fixtures/fmus/Gain``) and an ONNX model with 12 inputs and 12 outputs. Connections
form a DAG (each component is driven by earlier ones), so the system is valid: the timing is
that of a full, successful validation, not of an early exit. Then times

* ``api.compile_system`` in-process (best of ``--repeat`` runs: the cost of the checks),
* ``fmionnx validate`` as a fresh process (what CI and pre-commit pay, imports included),
* ``fmionnx validate --locked`` likewise, after ``fmionnx lock``,

and prints a table. A benchmark, not a test: run ``python benchmarks/validate_large.py``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import onnx
from onnx import TensorProto, helper

from fmionnx import api
from fmionnx.core.diagnostics import Severity
from fmionnx.kinds.fmu.build import build_fmu
from fmionnx.lock.check import lock_system

REPO = Path(__file__).resolve().parent.parent
COMPONENTS = 200
CONNECTIONS = 2000
ONNX_PORTS = 12
FMU_EVERY = 5  # every 5th component is a Gain FMU, the others ONNX models
#: Runs the console script's entry point in a fresh interpreter.
CLI = "from fmionnx.cli import main; main()"
#: Drivable input elements of Gain (u, v[0..2]) and the outputs that feed them.
FMU_INPUTS = ("u", "v[0]", "v[1]", "v[2]")
FMU_OUTPUTS = ("y", "w[0]", "w[1]", "w[2]")


def wide_onnx(path: Path) -> None:
    """``y_k = x_k + 1`` for k < 12, float32 [1] each: many ports, trivial graph."""
    one = helper.make_tensor("one", TensorProto.FLOAT, [1], [1.0])
    nodes = [helper.make_node("Add", [f"x{k}", "one"], [f"y{k}"]) for k in range(ONNX_PORTS)]
    graph = helper.make_graph(
        nodes,
        "wide",
        [helper.make_tensor_value_info(f"x{k}", TensorProto.FLOAT, [1]) for k in range(ONNX_PORTS)],
        [helper.make_tensor_value_info(f"y{k}", TensorProto.FLOAT, [1]) for k in range(ONNX_PORTS)],
        initializer=[one],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)


def system_text() -> str:
    """The system file: components ``c000``..``c199``, then the connections."""
    kinds = ["fmu" if i % FMU_EVERY == 0 else "onnx" for i in range(COMPONENTS)]
    lines = ["fmionnx: 1", "name: large", "run: {stop: 1, step: 0.01}", "components:"]
    for i, kind in enumerate(kinds):
        path = "Gain.fmu" if kind == "fmu" else "wide.onnx"
        lines.append(f"  c{i:03d}: {{kind: {kind}, path: {path}}}")
    lines.append("connections:")
    count = 0
    for i, kind in enumerate(kinds):
        earlier = [j for j in range(i) if kinds[j] == kind]
        if not earlier:
            continue
        inputs = FMU_INPUTS if kind == "fmu" else tuple(f"x{k}" for k in range(ONNX_PORTS))
        outputs = FMU_OUTPUTS if kind == "fmu" else tuple(f"y{k}" for k in range(ONNX_PORTS))
        for slot, port in enumerate(inputs):
            if count == CONNECTIONS:
                break
            source = earlier[(i * 7 + slot * 13) % len(earlier)]
            lines.append(f"  - c{source:03d}.{outputs[slot]} -> c{i:03d}.{port}")
            count += 1
    if count != CONNECTIONS:
        msg = f"generated {count} connections, expected {CONNECTIONS}"
        raise RuntimeError(msg)
    return "\n".join(lines) + "\n"


def main() -> None:
    """Generate, time, print."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="in-process runs (best is shown)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="fmionnx-bench-") as tmp:
        folder = Path(tmp)
        build_fmu(REPO / "tests" / "fixtures" / "fmus" / "Gain", folder / "Gain.fmu")
        wide_onnx(folder / "wide.onnx")
        system = folder / "large.yaml"
        system.write_text(system_text(), encoding="utf-8")

        times = []
        result = None
        for _ in range(args.repeat):
            start = time.perf_counter()
            result = api.compile_system(system)
            times.append(time.perf_counter() - start)
        assert result is not None
        errors = [d for d in result.diagnostics if d.severity is Severity.ERROR]
        warnings = [d for d in result.diagnostics if d.severity is Severity.WARNING]

        cli = []
        for _ in range(3):
            start = time.perf_counter()
            done = subprocess.run(
                [sys.executable, "-c", CLI, "validate", "--quiet", str(system)],
                capture_output=True,
                text=True,
                check=False,
                cwd=folder,
            )
            cli.append(time.perf_counter() - start)
        compiled = result.system
        lock_system(system)
        locked = []
        for _ in range(3):
            start = time.perf_counter()
            done_locked = subprocess.run(
                [sys.executable, "-c", CLI, "validate", "--quiet", "--locked", str(system)],
                capture_output=True,
                text=True,
                check=False,
                cwd=folder,
            )
            locked.append(time.perf_counter() - start)
    rows = [
        ("components", f"{COMPONENTS}"),
        ("connections", f"{CONNECTIONS}"),
        ("compiled", "yes" if compiled is not None else "no"),
        ("errors / warnings", f"{len(errors)} / {len(warnings)}"),
        (f"in-process compile_system, best of {args.repeat}", f"{min(times):.3f} s"),
        ("in-process compile_system, first run", f"{times[0]:.3f} s"),
        ("fmionnx validate (new process), best of 3", f"{min(cli):.3f} s"),
        ("fmionnx validate exit code", f"{done.returncode}"),
        ("fmionnx validate --locked (new process), best of 3", f"{min(locked):.3f} s"),
        ("fmionnx validate --locked exit code", f"{done_locked.returncode}"),
        ("target", "< 2 s"),
    ]
    width = max(len(name) for name, _ in rows)
    print(f"{'measure':<{width}}  value")
    print(f"{'-' * width}  {'-' * 10}")
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    if errors:
        print("\nfirst error:", errors[0].message)


if __name__ == "__main__":
    main()
