"""Resource bombs in small files are refused with E008 before anything is allocated.

Each model here is a file of a few hundred bytes (built by :mod:`tests.security.hostile`)
that asks MuJoCo or onnxruntime for gigabytes or minutes. ``validate`` and ``run`` refuse it
alike, with the limit's variable in the hint. Where a broken protection would take the
machine's memory, the command runs in a child process with a capped address space
(:func:`~tests.security.conftest.run_capped`), so that it fails instead.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.errors import ModelError, RunError
from fmionnx.core.runner import Wiring
from fmionnx.kinds.mujoco.interface import load_model
from fmionnx.kinds.registry import make_runner
from tests.conftest import REPO
from tests.security import hostile
from tests.security.conftest import run_capped

#: Seconds a refusal may take here (it takes well under one; MuJoCo without the limits:
#: minutes, or the machine's memory).
QUICK = 60


def _validate_capped(
    path: Path, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``fmionnx validate PATH`` in a capped child process."""
    code = (
        "import sys\n"
        "from fmionnx.cli import main\n"
        f"sys.argv = ['fmionnx', 'validate', {str(path)!r}]\n"
        "main()\n"
    )
    return run_capped(code, env=env)


@pytest.mark.parametrize("bomb", sorted(hostile.SCENE_BOMBS))
def test_a_scene_bomb_is_refused_before_mujoco_compiles_it(tmp_path: Path, bomb: str) -> None:
    path = hostile.scene(tmp_path / "bomb.xml", hostile.SCENE_BOMBS[bomb])
    done = _validate_capped(path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "error[E008 resource-limit]" in done.stdout
    assert "FMIONNX_MAX_SCENE_" in done.stdout
    assert "Traceback" not in done.stderr


def test_a_scene_bomb_is_refused_by_run_too(tmp_path: Path) -> None:
    hostile.scene(tmp_path / "bomb.xml", hostile.SCENE_BOMBS["replicate-1e9"])
    system = tmp_path / "bomb.yaml"
    system.write_text(
        "fmionnx: 1\nname: bomb\nrun: {stop: 0.01, step: 0.002}\n"
        "components:\n  world: {kind: mujoco, path: bomb.xml}\n",
        "utf-8",
    )
    code = (
        "import sys\nfrom fmionnx.cli import main\n"
        f"sys.argv = ['fmionnx', 'run', {str(system)!r}, '--out', {str(tmp_path / 'out')!r}]\n"
        "main()\n"
    )
    done = run_capped(code)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "error[E008 resource-limit]" in done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "out" / "run.json").exists()  # refused before the run


def test_a_scene_swapped_for_a_bomb_after_compiling_is_a_fault_before_mujoco_loads_it(
    tmp_path: Path,
) -> None:
    import fmionnx

    path = hostile.scene(tmp_path / "world.xml", '<worldbody><geom size="1"/></worldbody>')
    system = tmp_path / "world.yaml"
    system.write_text(
        "fmionnx: 1\nname: w\nrun: {stop: 0.01, step: 0.002}\n"
        "components:\n  world: {kind: mujoco, path: world.xml}\n",
        "utf-8",
    )
    component = fmionnx.load(system).compiled.components[0]
    hostile.scene(path, hostile.SCENE_BOMBS["replicate-1e9"])
    runner = make_runner(component, Wiring())
    with pytest.raises(RunError, match="FMIONNX_MAX_SCENE_ELEMENTS"):
        runner.instantiate()


def test_the_simulation_arena_is_checked_before_mujoco_allocates_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 300 hinged bodies are well within the element limit; MuJoCo sizes their arena at
    # about 30 MB, over a limit lowered to 10 MB.
    path = hostile.scene(tmp_path / "chain.xml", hostile.bodies(300))
    monkeypatch.setenv("FMIONNX_MAX_SCENE_BYTES", str(10 * 1024**2))
    with pytest.raises(ModelError, match="MuJoCo would allocate") as info:
        load_model(path)
    assert info.value.code is codes.RESOURCE_LIMIT
    assert "FMIONNX_MAX_SCENE_BYTES" in (info.value.hint or "")


@pytest.mark.parametrize(
    "scene",
    [
        REPO / "models" / "world" / "sign_course.xml",
        REPO / "tests" / "fixtures" / "scenes" / "rover.xml",
    ],
    ids=["reference", "rover"],
)
def test_real_scenes_stay_within_the_default_limits(scene: Path) -> None:
    model, _ = load_model(scene)
    assert model.nbody > 1


# -- ONNX ---------------------------------------------------------------------------------------


def test_an_external_initializer_of_805_million_elements_is_e008(tmp_path: Path) -> None:
    path = hostile.external_initializer(tmp_path / "model" / "big.onnx", 805_306_368)
    done = _validate_capped(path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "error[E008 resource-limit]" in done.stdout
    assert "stored tensor `w` of shape [805306368]" in done.stdout


def test_a_sparse_initializer_counts_its_dense_shape(tmp_path: Path) -> None:
    path = hostile.sparse_initializer(tmp_path / "sparse.onnx", [100_000, 100_000])
    done = _validate_capped(path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "[100000, 100000] has 10000000000 elements" in done.stdout


def test_the_tensors_a_model_stores_are_bounded_together(tmp_path: Path) -> None:
    path = hostile.initializers(tmp_path / "many.onnx", count=3, elements=400)
    done = _validate_capped(path, env={"FMIONNX_MAX_MODEL_ELEMENTS": "1000"})
    assert done.returncode == 1, done.stdout + done.stderr
    assert "more than 1000 elements together (at `w2`)" in done.stdout
    assert "FMIONNX_MAX_MODEL_ELEMENTS" in done.stdout


def test_sixteen_ports_at_the_array_limit_are_e008_together(tmp_path: Path) -> None:
    path = hostile.many_ports(tmp_path / "ports.onnx", count=16, elements=64 * 1024**2)
    done = _validate_capped(path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "its ports hold more than 134217728 elements together" in done.stdout
    assert "FMIONNX_MAX_PORT_ELEMENTS" in done.stdout


def test_a_hundred_byte_model_expanding_a_tensor_is_e008(tmp_path: Path) -> None:
    path = hostile.expand(tmp_path / "expand.onnx", [40_000, 40_000])
    assert path.stat().st_size < 200
    done = _validate_capped(path)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "computes `y` of shape [40000, 40000], 1600000000 elements" in done.stdout


def test_a_tensor_sized_by_an_input_value_is_a_fault_at_the_memory_limit(tmp_path: Path) -> None:
    hostile.expand(tmp_path / "expand.onnx", None)
    system = tmp_path / "expand.yaml"
    system.write_text(
        "fmionnx: 1\nname: expand\nrun: {stop: 0.2, step: 0.1}\ncomponents:\n"
        "  net: {kind: onnx, path: expand.onnx, parameters: {shape: [40000, 40000]}}\n",
        "utf-8",
    )
    code = (
        "import sys\nfrom fmionnx.cli import main\n"
        f"sys.argv = ['fmionnx', 'run', {str(system)!r}, '--out', {str(tmp_path / 'out')!r}]\n"
        "main()\n"
    )
    done = run_capped(code, env={"FMIONNX_MAX_ONNX_BYTES": str(512 * 1024**2)})
    assert done.returncode == 1, done.stdout + done.stderr
    run = json.loads((tmp_path / "out" / "run.json").read_text("utf-8"))
    assert run["status"] == "fault"
    assert run["error"]["component"] == "net"
    assert "needs a tensor of 6400000000 bytes" in run["error"]["message"]
    assert "FMIONNX_MAX_ONNX_BYTES" in run["error"]["message"]


# -- isolated models ----------------------------------------------------------------------------


def test_an_isolated_model_allocating_without_end_meets_its_address_space_limit(
    tmp_path: Path, fixture_fmu
) -> None:
    system = tmp_path / "hog.yaml"
    system.write_text(
        f"fmionnx: 1\nname: hog\nrun: {{stop: 1, step: 0.1}}\ncomponents:\n"
        f"  f: {{kind: fmu, path: {fixture_fmu('Faulty')}, parameters: {{mode: 13, failAt: 0.3}}}}\n"
        "  g: {kind: signal, outputs: {u: {constant: 1}}}\n"
        "connections:\n  - g.u -> f.u\n",
        "utf-8",
    )
    code = (
        "import sys\nfrom fmionnx.cli import main\n"
        f"sys.argv = ['fmionnx', 'run', {str(system)!r}, '--isolate', 'fmus', '--out', "
        f"{str(tmp_path / 'out')!r}]\nmain()\n"
    )
    limit = 1536 * 1024**2  # below the test's own cap: the child's limit is the one met
    done = run_capped(code, env={"FMIONNX_MAX_ISOLATED_BYTES": str(limit)})
    assert done.returncode == 1, done.stdout + done.stderr
    run = json.loads((tmp_path / "out" / "run.json").read_text("utf-8"))
    assert run["status"] == "fault"
    assert run["steps"] == 3  # every step before the one that ran out
    message = run["error"]["message"]
    assert run["error"]["component"] == "f"
    assert f"may use at most {limit} bytes of address space" in message
    assert "FMIONNX_MAX_ISOLATED_BYTES" in message


def test_the_json_report_gives_the_code_the_line_and_the_variable(tmp_path: Path) -> None:
    path = hostile.scene(tmp_path / "bomb.xml", hostile.SCENE_BOMBS["flexcomp-1500"])
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", "validate", str(path), "--format", "json"],
        capture_output=True, text=True, timeout=QUICK, check=False,
    )  # fmt: skip
    assert done.returncode == 1
    report = json.loads(done.stdout)
    (diagnostic,) = report["files"][0]["diagnostics"]
    assert diagnostic["code"] == "E008"
    assert (
        '`<flexcomp count="1500 1500 1">` makes 2250000 points at `bomb.xml:1`'
        in (diagnostic["message"])
    )
    assert "FMIONNX_MAX_SCENE_ELEMENTS" in diagnostic["hint"]


@pytest.mark.parametrize("command", ["validate", "run"])
def test_an_onnx_port_of_a_thousand_dimensions_is_e013(tmp_path: Path, command: str) -> None:
    """A port of more dimensions than a buffer can have: refused where validate reads the
    model, not numpy's ValueError when the run makes the port's array."""
    path = hostile.high_rank(tmp_path / "rank.onnx", 1000)
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", command, str(path), *(["--no-out"] * (command == "run"))],
        capture_output=True, text=True, timeout=QUICK, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 1, done.stdout + done.stderr
    output = " ".join((done.stdout + done.stderr).split())
    assert "E013" in output
    assert "port `x` has 1000 dimensions; fmionnx holds at most 32" in output
    assert "Traceback" not in done.stderr


def test_a_port_of_32_dimensions_runs(tmp_path: Path) -> None:
    path = hostile.high_rank(tmp_path / "rank.onnx", 32)
    done = subprocess.run(
        [sys.executable, "-m", "fmionnx", "run", str(path), "--no-out"],
        capture_output=True, text=True, timeout=QUICK, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
