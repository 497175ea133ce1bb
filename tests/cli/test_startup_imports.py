"""Each command imports only the libraries it uses (issue #14: a CLI that starts fast).

A command is run in a fresh interpreter, then the test lists which of the heavy libraries
ended up in ``sys.modules``. Nothing is timed (that is ``benchmarks/startup.py``'s job): the
test pins the import graph, which is what the start-up time follows. A system of FMUs only
must not pay for MuJoCo, onnxruntime, DDS, plotting, Dask or Zenoh; ``--help`` pays for none
of the simulation or compile libraries at all.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import build_fixture_fmu

#: Libraries no FMU-only command needs (the brief's list, and the ones other backends bring).
RUNTIME_EXTRAS = frozenset(
    {"mujoco", "onnxruntime", "onnx", "cyclonedds", "matplotlib", "dask", "distributed"}
    | {"zenoh", "pandas", "pyarrow", "rclpy", "rosbags", "mcap"}
)
#: What compiling or simulating needs, but printing help does not.
COMPILE_LIBRARIES = frozenset({"numpy", "fmpy", "lxml", "networkx", "ruamel", "pyssp_standard"})

PROBE = """\
import json, sys
from fmionnx.cli import main
sys.argv = ["fmionnx", *sys.argv[1:]]
try:
    main()
except SystemExit as exc:
    code = exc.code
else:
    code = 0
print(json.dumps({"code": code, "modules": sorted({m.split(".")[0] for m in sys.modules}),
                  "full": sorted(sys.modules)}), file=sys.stderr)
"""

SYSTEM = """\
fmionnx: 1
name: fmus_only
run: {stop: 0.1, step: 0.01}
components:
  gain: {kind: fmu, path: Gain.fmu}
  integrator: {kind: fmu, path: Integrator.fmu}
connections:
  - gain.y -> integrator.u
"""


#: A signal's waveform drives an FMU: the signal kind's compiled settings are read back too.
SIGNALS = """\
fmionnx: 1
name: stepped
run: {stop: 0.1, step: 0.01}
components:
  source: {kind: signal, outputs: {v: {step: {time: 0.05, final: 2}}}}
  integrator: {kind: fmu, path: Integrator.fmu}
connections:
  - source.v -> integrator.u
"""


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    here = tmp_path_factory.mktemp("startup")
    for name in ("Gain", "Integrator"):
        shutil.copy(build_fixture_fmu(name), here / f"{name}.fmu")
    (here / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    (here / "signals.yaml").write_text(SIGNALS, encoding="utf-8")
    (here / "probe.py").write_text(PROBE, encoding="utf-8")
    return here


def loaded(
    folder: Path, *args: str, full: bool = False, env: dict[str, str] | None = None
) -> set[str]:
    """Top-level packages in ``sys.modules`` after ``fmionnx ARGS`` (which must succeed);
    ``full``: every module's full name; ``env``: variables set for the command."""
    done = subprocess.run(
        [sys.executable, "probe.py", *args],
        cwd=folder,
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
        env={**os.environ, **(env or {})},
    )
    report = json.loads(done.stderr.strip().splitlines()[-1])
    assert report["code"] == 0, done.stderr
    return set(report["full" if full else "modules"])


def test_help_loads_no_compile_or_simulation_library(folder: Path) -> None:
    modules = loaded(folder, "--help")
    assert modules & (RUNTIME_EXTRAS | COMPILE_LIBRARIES | {"pydantic"}) == set()


#: What typer's help renderer imports at its top but fmionnx never uses: Markdown help texts
#: (markdown_it, pygments via rich.syntax) and pretty tracebacks (rich.pretty, attrs).
HELP_UNUSED = frozenset({"rich.markdown", "rich.syntax", "rich.traceback", "rich.pretty"})
HELP_UNUSED_PACKAGES = frozenset({"markdown_it", "mdurl", "pygments", "attr", "attrs"})


@pytest.mark.parametrize("args", [("--help",), ("run", "--help"), ("validate", "-h")])
def test_help_loads_neither_markdown_nor_tracebacks(folder: Path, args: tuple[str, ...]) -> None:
    modules = loaded(folder, *args, full=True)
    assert "typer.rich_utils" in modules  # the help was rendered by typer's rich renderer
    assert modules & (HELP_UNUSED | HELP_UNUSED_PACKAGES) == set()


def test_a_command_s_help_loads_none_either(folder: Path) -> None:
    modules = loaded(folder, "run", "--help")
    assert modules & (RUNTIME_EXTRAS | COMPILE_LIBRARIES) == set()


def test_validating_a_system_of_fmus_loads_no_other_runtime(folder: Path) -> None:
    assert loaded(folder, "validate", "system.yaml") & RUNTIME_EXTRAS == set()


@pytest.mark.parametrize("isolate", ["fmus", "none"])
def test_running_a_system_of_fmus_loads_no_other_runtime(folder: Path, isolate: str) -> None:
    modules = loaded(folder, "run", "system.yaml", "-q", "--out", f"out-{isolate}", "--isolate", isolate)  # fmt: skip
    assert (folder / f"out-{isolate}" / "results.csv").exists()
    assert modules & RUNTIME_EXTRAS == set()
    assert "fmpy" in modules  # the probe sees what a run does load


def test_running_one_fmu_needs_no_graph_library(folder: Path) -> None:
    """A lone model has no connection to order: networkx stays out too; and it is no YAML
    file, so the YAML parser (ruamel) stays out (it loads when a document is read)."""
    modules = loaded(folder, "run", "Integrator.fmu", "-q", "--out", "out-single")
    assert modules & (RUNTIME_EXTRAS | {"networkx", "ruamel"}) == set()


def test_a_system_file_still_loads_the_yaml_parser(folder: Path) -> None:
    """The lazy import is taken where a document is read (the probe sees ruamel then)."""
    assert "ruamel" in loaded(folder, "validate", "system.yaml")


def test_plots_load_matplotlib_only_when_asked(folder: Path) -> None:
    """Drawn in this process when plot workers are off (on a machine with cores to spare the
    plot worker imports matplotlib instead: tests/results/test_plot_worker.py)."""
    worker_off = {"FMIONNX_PLOT_WORKER": "0"}
    modules = loaded(folder, "run", "Integrator.fmu", "-q", "--out", "out-plot", "--plot", env=worker_off)  # fmt: skip
    assert "matplotlib" in modules
    assert modules & (RUNTIME_EXTRAS - {"matplotlib"}) == set()
    assert (folder / "out-plot" / "signals.png").is_file()


def test_validating_the_reference_scenario_loads_no_runtime_it_does_not_use(
    folder: Path,
) -> None:
    """Compiling reads the models (MuJoCo compiles the scene, onnx reads the graph) but runs
    none: onnxruntime, DDS, plotting and the sweep and Zenoh libraries stay out."""
    from tests.conftest import REPO, built_model

    for name in ("ReadOdometry.fmu", "SignTrackingLogic.fmu", "sign_detector.onnx"):
        built_model(name)
    system = REPO / "systems" / "sign_follower.yaml"
    modules = loaded(folder, "validate", str(system))
    assert {"mujoco", "onnx"} <= modules  # the probe sees what reading the models loads
    assert modules & (RUNTIME_EXTRAS - {"mujoco", "onnx", "rosbags"}) == set()
    assert "onnxruntime" not in modules


#: What a system file needs and a lone model does not: the system-file types (their
#: ``components`` union of every kind's entry model), the other kinds, the YAML front end,
#: the compilers of connections, checks, plots, loops and system inputs, and the plot writers.
LONE_MODEL_UNUSED = frozenset(
    {"fmionnx.spec.model", "fmionnx.spec.yaml", "fmionnx.spec.frontends"}
    | {"fmionnx.kinds.onnx.kind", "fmionnx.kinds.mujoco.kind", "fmionnx.kinds.signal.kind"}
    | {"fmionnx.compile.compiler", "fmionnx.compile.checks", "fmionnx.compile.checkparse"}
    | {"fmionnx.compile.plots", "fmionnx.compile.loops", "fmionnx.compile.sysinputs"}
    | {"fmionnx.results.plots", "fmionnx.results.scenedraw"}  # nothing to draw
)


@pytest.mark.parametrize("isolate", ["fmus", "none"])
def test_running_one_fmu_loads_no_system_file_types(folder: Path, isolate: str) -> None:
    out = f"out-lone-{isolate}"
    modules = loaded(folder, "run", "Integrator.fmu", "-q", "--out", out, "--isolate", isolate, full=True)  # fmt: skip
    assert (folder / out / "run.json").exists()
    assert "fmionnx.kinds.fmu.kind" in modules  # the probe sees what the run does load
    assert modules & LONE_MODEL_UNUSED == set()


def test_a_system_file_still_loads_them(folder: Path) -> None:
    modules = loaded(folder, "validate", "system.yaml", full=True)
    assert {"fmionnx.spec.model", "fmionnx.compile.compiler"} <= modules


def test_a_system_read_back_from_the_compile_cache_loads_no_pydantic(
    folder: Path, tmp_path: Path
) -> None:
    """The system file's entry models are pydantic's (about 0.09 s to import, with typer's
    adapters when typer builds them): needed to compile a system, not to read one back."""
    env = {"FMIONNX_CACHE": str(tmp_path / "cache"), "FMIONNX_COMPILE_CACHE": "1"}
    assert "pydantic" in loaded(folder, "validate", "system.yaml", env=env)  # compiled
    assert "pydantic" not in loaded(folder, "validate", "system.yaml", env=env)  # read back


def test_a_signal_read_back_from_the_compile_cache_loads_no_pydantic(
    folder: Path, tmp_path: Path
) -> None:
    """The signal kind's waveforms came with its entry model (pydantic) until they were
    apart: a study's workers, forked from a server that imports every kind, paid for it."""
    env = {"FMIONNX_CACHE": str(tmp_path / "cache"), "FMIONNX_COMPILE_CACHE": "1"}
    assert "pydantic" in loaded(folder, "validate", "signals.yaml", env=env)  # compiled
    assert "pydantic" not in loaded(folder, "validate", "signals.yaml", env=env)  # read back


def test_a_lone_fmu_read_back_from_the_compile_cache_loads_no_pydantic(
    folder: Path, tmp_path: Path
) -> None:
    """A lone model's compile loads its kind's entry model and the run settings' types
    (pydantic): a third of a lone FMU's start, which its second run no longer pays."""
    env = {"FMIONNX_CACHE": str(tmp_path / "cache"), "FMIONNX_COMPILE_CACHE": "1"}
    for out, compiled in (("out-lone-miss", True), ("out-lone-hit", False)):
        modules = loaded(folder, "run", "Integrator.fmu", "-q", "--out", out, env=env)
        assert ("pydantic" in modules) is compiled
        assert (folder / out / "results.csv").is_file()


@pytest.mark.parametrize("isolate", ["guardian", "none"])
def test_a_run_that_isolates_no_component_loads_no_isolation_proxy(
    folder: Path, isolate: str
) -> None:
    """Which components are isolated is a look at the system; the proxy (pipes, shared
    memory, the zygote's launcher) is for a run that does isolate one."""
    out = f"out-proxy-{isolate}"
    modules = loaded(folder, "run", "Integrator.fmu", "-q", "--out", out, "--isolate", isolate, full=True)  # fmt: skip
    assert "fmionnx.runtime.isolated.factory" in modules  # the probe sees the look taken
    assert "fmionnx.runtime.isolated.proxy" not in modules


def test_validating_a_model_read_back_loads_neither_fmpy_nor_pydantic(
    folder: Path, tmp_path: Path
) -> None:
    """A lone model's check (its compile, FMPy's validation) is kept when it found no error:
    the next `validate` of the unchanged FMU reads it back."""
    env = {"FMIONNX_CACHE": str(tmp_path / "cache"), "FMIONNX_COMPILE_CACHE": "1"}
    assert {"fmpy", "pydantic"} <= loaded(folder, "validate", "Integrator.fmu", env=env)
    assert loaded(folder, "validate", "Integrator.fmu", env=env) & {"fmpy", "pydantic"} == set()
