"""The CLI starts without the simulation libraries: ``--help`` and ``validate`` load no numpy,
fmpy, onnxruntime or MuJoCo at import time (they load when a model is read or a system runs)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest


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


# -- what each light command imports, measured with `python -X importtime` ----------------------
#
# Each command runs in a fresh interpreter under `-X importtime`, which lists every module the
# process imported with the time it took (the numbers are not asserted: tests check behaviour,
# `benchmarks/startup.py` times). A heavy library that comes back into a command that does not
# need it fails here, naming the chain of imports that brought it.

#: Libraries only some runs need: none of the light commands may import them.
HEAVY = frozenset(
    {"matplotlib", "pandas", "pyarrow", "dask", "distributed", "onnxruntime", "mujoco", "glfw"}
    | {"cyclonedds", "zenoh", "rclpy", "mcap", "rosbags.typesys.stores"}
)
#: What compiling a system file needs (and a compile read back from the cache does not).
COMPILING = frozenset(
    {"networkx", "ruamel.yaml", "lxml", "fmpy", "numpy", "onnx", "rosbags"}
    | {"fmionnx.spec.model", "fmionnx.spec.yaml", "fmionnx.compile.compiler"}
)
#: The other kinds (a lone FMU's commands use the FMU kind only; a system file's types hold
#: every kind's entry model).
OTHER_KINDS = frozenset(
    {"fmionnx.kinds.onnx.kind", "fmionnx.kinds.mujoco.kind", "fmionnx.kinds.signal.kind"}
)

FMU_SYSTEM = """\
fmionnx: 1
name: fmus_only
run: {stop: 0.1, step: 0.01}
components:
  gain: {kind: fmu, path: Gain.fmu}
  integrator: {kind: fmu, path: Integrator.fmu}
connections:
  - gain.y -> integrator.u
"""

# `-X importtime` does not report modules imported through `importlib.import_module` (the kind
# table imports kinds that way), so the probe also prints every module loaded at the end.
IMPORTTIME_PROBE = """\
import json, sys
from fmionnx.cli import main
sys.argv = ["fmionnx", *sys.argv[1:]]
code = 0
try:
    main()
except SystemExit as exc:
    code = exc.code
print("modules: " + json.dumps(sorted(sys.modules)), file=sys.stderr)
sys.exit(code)
"""


@dataclass(frozen=True)
class Imports:
    """The modules a command imported, each with the chain of importers that brought it."""

    chains: dict[str, tuple[str, ...]]

    def of(self, wanted: frozenset[str]) -> dict[str, str]:
        """Each module in ``wanted`` (or below it: ``rosbags`` covers ``rosbags.x``) that was
        imported, with the chain that brought the first of them."""
        found = {}
        for name, chain in self.chains.items():
            for root in wanted:
                if name == root or name.startswith(root + "."):
                    found.setdefault(root, " <- ".join((name, *chain)))
        return found


def importtime(folder: Path, *args: str) -> Imports:
    """``fmionnx ARGS`` in ``folder`` under ``python -X importtime`` (it must succeed)."""
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "probe_importtime.py", *args],
        cwd=folder, capture_output=True, text=True, check=False, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    rows = []
    loaded: list[str] = []
    for line in done.stderr.splitlines():
        if line.startswith("modules: "):
            loaded = json.loads(line.removeprefix("modules: "))
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        name = line.split("|")[2]
        rows.append((len(name) - len(name.lstrip()), name.strip()))
    # -X importtime prints a module after everything it imported, one level deeper: a
    # module's importers are the next lines with a shallower indentation.
    chains: dict[str, tuple[str, ...]] = {}
    for index, (depth, name) in enumerate(rows):
        chain, level = [], depth
        for deeper, importer in rows[index + 1 :]:
            if deeper < level:
                chain.append(importer)
                level = deeper
        chains.setdefault(name, tuple(chain))
    assert "fmionnx.cli" in chains  # the probe saw the command's imports
    for name in loaded:
        chains.setdefault(name, ("(through importlib.import_module)",))
    return Imports(chains)


@pytest.fixture(scope="module")
def commands(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with two fixture FMUs, a system of them and the probe; its own cache folder."""
    from tests.conftest import build_fixture_fmu

    here = tmp_path_factory.mktemp("importtime")
    for name in ("Gain", "Integrator"):
        shutil.copy(build_fixture_fmu(name), here / f"{name}.fmu")
    (here / "system.yaml").write_text(FMU_SYSTEM, encoding="utf-8")
    (here / "probe_importtime.py").write_text(IMPORTTIME_PROBE, encoding="utf-8")
    return here


@pytest.fixture(autouse=True)
def _module_cache(commands: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """One compile cache for this module's commands (a later command finds an earlier one's
    compile), so the cache's hits are what is measured where a test says so."""
    monkeypatch.setenv("FMIONNX_CACHE", str(commands / "cache"))


def test_importtime_help_imports_no_library_a_command_uses(commands: Path) -> None:
    found = importtime(commands, "--help").of(HEAVY | COMPILING | {"pydantic"})
    assert found == {}


def test_importtime_validating_a_system_of_fmus_imports_no_other_runtime(commands: Path) -> None:
    """Compiling it reads its FMUs (fmpy) and orders them (with the compile's own graph code:
    networkx stays out); the system-file types hold every kind's entry model, so only the
    other kinds' libraries stay out."""
    found = importtime(commands, "validate", "system.yaml").of(HEAVY | {"onnx", "networkx"})
    assert found == {}


def test_importtime_validating_it_again_reads_the_compile_back(commands: Path) -> None:
    """The second validate of an unchanged system: no parser, no model library, no graph."""
    importtime(commands, "validate", "system.yaml")  # compiled (or already cached)
    found = importtime(commands, "validate", "system.yaml").of(HEAVY | COMPILING)
    assert found == {}


def test_importtime_graph_of_a_cached_system_imports_no_graph_library(commands: Path) -> None:
    importtime(commands, "validate", "system.yaml")
    found = importtime(commands, "graph", "system.yaml").of(HEAVY | COMPILING)
    assert found == {}


def test_importtime_the_reference_system_read_back_needs_none_of_its_model_libraries(
    commands: Path,
) -> None:
    """MuJoCo, onnx, fmpy and the ROS 2 message stores compile the reference system;
    read back from the cache, none of them is loaded (nor numpy: nothing is computed)."""
    from tests.conftest import REPO, built_model

    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    system = str(REPO / "systems" / "sign_follower.yaml")
    importtime(commands, "validate", system)
    found = importtime(commands, "validate", system).of(HEAVY | COMPILING)
    assert found == {}


def test_importtime_inspect_of_an_fmu_imports_no_other_kind(commands: Path) -> None:
    unused = HEAVY | OTHER_KINDS | {"onnx", "networkx", "ruamel.yaml", "fmionnx.spec.model"}
    assert importtime(commands, "inspect", "Gain.fmu").of(unused) == {}


def test_importtime_a_lone_fmu_runs_without_plots_graphs_or_other_kinds(commands: Path) -> None:
    found = importtime(commands, "run", "Integrator.fmu", "-q", "--out", "lone").of(
        HEAVY | OTHER_KINDS | {"networkx", "ruamel.yaml", "onnx", "fmionnx.spec.model"}
    )
    assert found == {}
    assert (commands / "lone" / "results.csv").exists()


def test_importtime_a_run_without_plots_pays_nothing_for_matplotlib(commands: Path) -> None:
    importtime(commands, "validate", "system.yaml")
    found = importtime(commands, "run", "system.yaml", "-q", "--out", "system-run").of(
        HEAVY | {"networkx", "ruamel.yaml", "fmionnx.spec.model", "fmionnx.compile.compiler"}
    )
    assert found == {}
