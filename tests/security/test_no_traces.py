"""A run leaves nothing behind but its results and the documented caches.

A run of a system with an FMU, an ONNX model and a MuJoCo scene (whose cloth makes MuJoCo
warn while compiling) under a fresh ``HOME``, ``TMPDIR`` and working folder may leave only
its output folder, fmionnx's own cache and matplotlib's font cache (the list in
docs/security.md, "Nothing is left behind"). MuJoCo wrote ``MUJOCO_LOG.TXT`` into the working
folder at every warning; onnxruntime 1.2x+ writes a device id and a queue of usage events
under ``~/.cache/Microsoft/DeveloperTools`` and ``$TMPDIR/.ses`` unless told not to.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from onnx import TensorProto, helper

#: What a run may leave outside its output folder: (folder, path pattern relative to it).
ALLOWED = (
    ("home", ".cache/fmionnx"),  # ours: unpacked SSPs, native kernels built here
    ("home", ".cache/matplotlib"),  # matplotlib's font list, built once
    ("home", ".config/matplotlib"),  # matplotlib's configuration folder (made empty)
)

SCENE = """<mujoco model="clean">
  <option timestep="0.002"/>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="box" pos="0 0 0.5"><freejoint/><geom type="box" size="0.1 0.1 0.1"/></body>
    <flexcomp name="cloth" type="grid" count="2 2 1" spacing="0.1 0.1 0.1" dim="2" pos="1 1 1"/>
  </worldbody>
  <sensor><framepos name="box_pos" objtype="body" objname="box"/></sensor>
</mujoco>
"""

SYSTEM = """fmionnx: 1
name: clean
run: {{stop: 0.1, step: 0.01}}
components:
  world: {{kind: mujoco, path: scene.xml}}
  net: {{kind: onnx, path: square.onnx}}
  gain: {{kind: fmu, path: {gain}, parameters: {{u: 1}}}}
connections:
  - world.box_pos -> net.x
  - net.y -> gain.v
plots:
  - {{y: [gain.w]}}
"""


def _left(root: Path) -> list[str]:
    """Every file and folder under ``root``'s home, temporary and working folders but the
    output folder and what :data:`ALLOWED` names."""
    found = []
    for place in ("home", "tmp", "work"):
        for path in sorted((root / place).rglob("*")):
            relative = path.relative_to(root / place).as_posix()
            if place == "work" and relative.split("/")[0] in {
                "out",
                "scene.xml",
                "square.onnx",
                "system.yaml",
            }:
                continue
            if any(
                place == folder
                and (
                    relative == allowed
                    or relative.startswith(allowed + "/")
                    or allowed.startswith(relative + "/")
                )
                for folder, allowed in ALLOWED
            ):
                continue
            found.append(f"{place}/{relative}")
    return found


@pytest.mark.parametrize("isolate", ["fmus", "all"], ids=["default", "isolate-all"])
def test_a_run_under_a_fresh_home_leaves_only_the_documented_caches(
    tmp_path: Path, fixture_fmu, isolate: str
) -> None:
    for place in ("home", "tmp", "work"):
        (tmp_path / place).mkdir()
    work = tmp_path / "work"
    (work / "scene.xml").write_text(SCENE, "utf-8")
    graph = helper.make_graph(
        [helper.make_node("Mul", ["x", "x"], ["y"])],
        "square",
        [helper.make_tensor_value_info("x", TensorProto.DOUBLE, [3])],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, [3])],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    (work / "square.onnx").write_bytes(model.SerializeToString())
    (work / "system.yaml").write_text(SYSTEM.format(gain=fixture_fmu("Gain")), "utf-8")
    environment = {
        key: value
        for key, value in os.environ.items()
        if not key.startswith(("XDG_", "MPL", "FMIONNX_", "ORT_"))
    }
    environment |= {"HOME": str(tmp_path / "home"), "TMPDIR": str(tmp_path / "tmp")}
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", "run", "system.yaml", "--out", "out",
         "--isolate", isolate],
        capture_output=True, text=True, timeout=300, check=False, cwd=work, env=environment,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "is not rigid" in done.stdout + done.stderr  # MuJoCo warned (and logged nowhere)
    assert (work / "out" / "results.csv").is_file()
    assert _left(tmp_path) == []
