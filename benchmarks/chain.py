"""Master overhead: a chain of N ``Gain`` FMUs stepped five ways, side by side in one process.

The system is the ``Gain`` test FMU (FMI 2 co-simulation, ``y = k*u``, ``k = 2``) repeated N
times and connected ``g[i-1].y -> g[i].u``; the head's input is held at 1, so after the
values have propagated the tail's output is exactly ``2**N`` (every contender is checked).
Each contender performs, per FMU and step, the same three FMI calls (set the input, do the
step, get the output); what differs is the code around them:

* ``fmionnx``: the real pipeline: a system file compiled by ``fmionnx.load`` and run by the
  in-process master with recording off (``RunOptions(record=())``); the master's own
  ``wall_time`` covers the stepping loop only. The chain is one group of FMI 2 co-simulation
  FMUs, which the master steps with its native kernel (one C call per step);
* ``fmionnx, Python path``: the same with ``FMIONNX_NATIVE=0`` (a Python call per FMU step);
* ``fmpy loop``: a hand-written loop over fmpy's ``FMU2Slave.setReal/doStep/getReal``;
* ``ctypes floor``: the raw FMI C functions of the loaded library with value-reference and
  value arrays prepared once (statuses checked): no master can make fewer Python calls;
* ``fmpy.simulate_fmu`` (N = 1 only): marginal cost per step from two runs of different
  length, so its setup is not counted; it records ``y`` at every step, as it always records;
* ``libcosimpy``: libcosim's fixed-step master (C++), stepped by ``execution.step(n)``.

Every contender instantiates fresh FMUs per repetition and times only its stepping loop.
Repetitions are interleaved (the order rotates) so that drifting machine load hits every
contender alike; the tables report medians.
"""

from __future__ import annotations

import ctypes
import itertools
import os
import shutil
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
GAIN_SOURCE = REPO / "tests" / "fixtures" / "fmus" / "Gain"
HEAD_INPUT = 1.0
GAIN = 2.0  # the FMU's default k
FMI_WARNING = 1

FMIONNX = "fmionnx"
FMIONNX_PYTHON = "fmionnx, Python path"
FMPY_LOOP = "fmpy loop"
CTYPES_FLOOR = "ctypes floor"
SIMULATE_FMU = "fmpy.simulate_fmu"
LIBCOSIM = "libcosimpy"


@dataclass(frozen=True)
class Chain:
    """One benchmark case: ``n`` Gain FMUs, ``steps`` steps of ``step`` seconds."""

    fmu: Path
    unzipped: Path
    n: int
    steps: int
    step: float = 1e-3

    @property
    def stop(self) -> float:
        """Stop time of the run (start is 0)."""
        return self.steps * self.step

    @property
    def expected(self) -> float:
        """The tail's output once the head's input has propagated: ``1 * 2**n``."""
        return HEAD_INPUT * GAIN**self.n


@dataclass(frozen=True)
class Sample:
    """One timed repetition: loop seconds over ``steps`` steps, and the tail's final output."""

    seconds: float
    steps: int
    final: float

    @property
    def per_step(self) -> float:
        """Seconds per step of the whole chain."""
        return self.seconds / self.steps


#: A prepared contender: each call instantiates, runs one timed loop and frees.
RunOnce = Callable[[], Sample]
#: Prepares a contender for a chain, or returns a reason why it does not apply.
Prepare = Callable[[Chain], "RunOnce | str"]


@contextmanager
def built_gain(folder: Path) -> Iterator[tuple[Path, Path]]:
    """Compile the Gain FMU into ``folder`` and extract it once; yields (fmu, unzipped dir)."""
    from fmpy import extract

    from fmionnx.kinds.fmu.build import build_fmu

    fmu = folder / "Gain.fmu"
    if not fmu.exists():
        build_fmu(GAIN_SOURCE, fmu)
    unzipped = Path(extract(str(fmu), unzipdir=str(folder / "Gain")))
    try:
        yield fmu, unzipped
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)


def value_references(chain: Chain) -> tuple[int, int]:
    """Value references of ``u`` and ``y`` read from the model description."""
    from fmpy import read_model_description

    md = read_model_description(str(chain.unzipped))
    vrs = {v.name: int(v.valueReference) for v in md.modelVariables}
    return vrs["u"], vrs["y"]


# -- fmionnx -----------------------------------------------------------------------------------


def system_text(chain: Chain) -> str:
    """The chain as a system file; the FMU path is absolute (the file lives in a temp dir)."""
    lines = [
        "fmionnx: 1",
        f"name: gain_chain_{chain.n}",
        f"run: {{start: 0, stop: {chain.stop!r}, step: {chain.step!r}}}",
        "components:",
    ]
    for i in range(chain.n):
        head = f", parameters: {{u: {HEAD_INPUT!r}}}" if i == 0 else ""
        lines.append(f"  g{i}: {{kind: fmu, path: '{chain.fmu.as_posix()}'{head}}}")
    lines.append("connections:" if chain.n > 1 else "connections: []")
    lines.extend(f"  - g{i - 1}.y -> g{i}.u" for i in range(1, chain.n))
    return "\n".join(lines) + "\n"


@contextmanager
def native_kernel(enabled: bool) -> Iterator[None]:
    """``FMIONNX_NATIVE=0`` while a disabled run prepares; the environment restored after."""
    if enabled:
        yield
        return
    before = os.environ.get("FMIONNX_NATIVE")
    os.environ["FMIONNX_NATIVE"] = "0"
    try:
        yield
    finally:
        if before is None:
            del os.environ["FMIONNX_NATIVE"]
        else:
            os.environ["FMIONNX_NATIVE"] = before


def prepare_fmionnx_python(chain: Chain) -> RunOnce | str:
    """fmionnx with its native kernel off: the master's Python loop over the FMU runners."""
    return prepare_fmionnx(chain, native=False)


def prepare_fmionnx(chain: Chain, *, native: bool = True) -> RunOnce | str:
    """Compile the system file once; each repetition is one ``System.run`` without recording."""
    import fmionnx
    from fmionnx.core.types import PortRef
    from fmionnx.runtime.result import RunOptions, RunStatus

    folder = Path(tempfile.mkdtemp(prefix="fmionnx-chain-"))
    try:
        path = folder / "chain.yaml"
        path.write_text(system_text(chain), encoding="utf-8")
        system = fmionnx.load(path)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    tail = PortRef(f"g{chain.n - 1}", "y")
    # Untimed check that the chain computes what the others do (recording only the tail).
    with native_kernel(native):
        check = system.run(stop_time=3 * chain.step, signals=(tail,), isolate="none")
    if not native and check.details.get("native"):
        msg = "FMIONNX_NATIVE=0 did not turn the native kernel off"
        raise RuntimeError(msg)
    final = float(check[f"{tail.component}.y"][-1])
    silent = RunOptions(record=())

    def run_once() -> Sample:
        with native_kernel(native):
            result = system.run(options=silent)
        if result.status is not RunStatus.COMPLETED:
            msg = f"fmionnx run ended {result.status}: {result.error}"
            raise RuntimeError(msg)
        return Sample(result.wall_time, result.steps_done, final)

    return run_once


# -- fmpy's FMU2Slave ----------------------------------------------------------------------------


def _slaves(chain: Chain, vr_u: int) -> list[Any]:
    """``n`` instantiated and initialized FMU2Slave instances; the head's input set to 1."""
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(chain.unzipped))
    slaves = []
    for i in range(chain.n):
        slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=str(chain.unzipped),
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=f"g{i}",
        )
        slave.instantiate()
        slave.setupExperiment(startTime=0.0, stopTime=chain.stop)
        slave.enterInitializationMode()
        slave.setReal([vr_u], [HEAD_INPUT if i == 0 else 0.0])
        slave.exitInitializationMode()
        slaves.append(slave)
    return slaves


def _free(slaves: list[Any]) -> None:
    for slave in slaves:
        slave.terminate()
        slave.freeInstance()


def prepare_fmpy_loop(chain: Chain) -> RunOnce | str:
    """Per FMU and step: ``setReal([vr_u], [y])``, ``doStep``, ``getReal([vr_y])``."""
    vr_u, vr_y = value_references(chain)

    def run_once() -> Sample:
        slaves = _slaves(chain, vr_u)
        u_refs, y_refs = [vr_u], [vr_y]
        h, steps = chain.step, chain.steps
        y = HEAD_INPUT
        try:
            started = time.perf_counter()
            for n in range(steps):
                t = n * h
                y = HEAD_INPUT
                for slave in slaves:
                    slave.setReal(u_refs, [y])
                    slave.doStep(t, h)
                    y = slave.getReal(y_refs)[0]
            seconds = time.perf_counter() - started
        finally:
            _free(slaves)
        return Sample(seconds, steps, float(y))

    return run_once


# -- the ctypes floor ----------------------------------------------------------------------------


def prepare_ctypes_floor(chain: Chain) -> RunOnce | str:
    """fmi2SetReal / fmi2DoStep / fmi2GetReal straight from the library, arrays made once."""
    vr_u, vr_y = value_references(chain)

    def run_once() -> Sample:
        slaves = _slaves(chain, vr_u)
        calls = []
        source = (ctypes.c_double * 1)(HEAD_INPUT)  # the head's held input
        for slave in slaves:
            dll, instance = slave.dll, ctypes.c_void_p(slave.component)
            u = (ctypes.c_double * 1)()
            y = (ctypes.c_double * 1)()
            set_args = (instance, (ctypes.c_uint * 1)(vr_u), 1, u)
            get_args = (instance, (ctypes.c_uint * 1)(vr_y), 1, y)
            calls.append(
                (
                    source,
                    u,
                    dll.fmi2SetReal,
                    set_args,
                    dll.fmi2DoStep,
                    instance,
                    dll.fmi2GetReal,
                    get_args,
                )
            )
            source = y
        h, steps = chain.step, chain.steps
        try:
            started = time.perf_counter()
            for n in range(steps):
                t = n * h
                for src, u, set_real, set_args, do_step, instance, get_real, get_args in calls:
                    u[0] = src[0]
                    if set_real(*set_args) > FMI_WARNING:
                        raise RuntimeError("fmi2SetReal failed")
                    if do_step(instance, t, h, 1) > FMI_WARNING:
                        raise RuntimeError("fmi2DoStep failed")
                    if get_real(*get_args) > FMI_WARNING:
                        raise RuntimeError("fmi2GetReal failed")
            seconds = time.perf_counter() - started
        finally:
            _free(slaves)
        return Sample(seconds, steps, float(source[0]))

    return run_once


# -- fmpy.simulate_fmu ---------------------------------------------------------------------------


def prepare_simulate_fmu(chain: Chain) -> RunOnce | str:
    """One FMU only: simulate_fmu has no way to connect several FMUs."""
    if chain.n != 1:
        return "one FMU only"
    from fmpy import read_model_description, simulate_fmu

    md = read_model_description(str(chain.unzipped))

    def simulate(steps: int) -> tuple[float, float]:
        started = time.perf_counter()
        result = simulate_fmu(
            str(chain.unzipped),
            validate=False,
            start_time=0.0,
            stop_time=steps * chain.step,
            output_interval=chain.step,
            start_values={"u": HEAD_INPUT},
            output=["y"],
            model_description=md,
        )
        return time.perf_counter() - started, float(result["y"][-1])

    def run_once() -> Sample:
        short, _ = simulate(1)
        full, final = simulate(chain.steps)
        return Sample(max(full - short, 0.0), chain.steps - 1, final)

    return run_once


# -- libcosimpy ----------------------------------------------------------------------------------


def libcosim_problem() -> str | None:
    """Why libcosimpy cannot run here (None when it imports and loads its library)."""
    try:
        from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    except Exception as exc:  # not installed, or its native library does not load
        return f"libcosimpy unavailable: {type(exc).__name__}: {exc}"
    log_output_level(CosimLogLevel.ERROR)
    return None


def prepare_libcosim(chain: Chain) -> RunOnce | str:
    """libcosim's fixed-step algorithm over the same FMU, connections made in libcosim."""
    problem = libcosim_problem()
    if problem is not None:
        return problem
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    vr_u, vr_y = value_references(chain)
    nanos = round(chain.step * 1e9)

    def build() -> tuple[Any, list[int], list[Any]]:
        execution = CosimExecution.from_step_size(step_size=nanos)
        slaves = [
            CosimLocalSlave(fmu_path=str(chain.fmu), instance_name=f"g{i}") for i in range(chain.n)
        ]
        indices = [execution.add_local_slave(local_slave=s) for s in slaves]
        for a, b in itertools.pairwise(indices):
            if execution.connect_real_variables(a, vr_y, b, vr_u) != 0:  # C status, 0 = success
                raise RuntimeError("libcosim refused a connection")
        execution.real_initial_value(indices[0], vr_u, HEAD_INPUT)
        execution.real_time_simulation_enabled(False)
        return execution, indices, slaves

    # Untimed check: libcosim transfers after each step (Jacobi), so N + 2 steps propagate.
    execution, indices, _slaves_alive = build()
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer=observer)
    if not execution.step(chain.n + 2):
        raise RuntimeError("libcosim check run failed")
    final = float(observer.last_real_values(indices[-1], [vr_y])[0])
    del execution, observer, _slaves_alive

    def run_once() -> Sample:
        execution, _, slaves = build()
        if not execution.step(1):  # initialization happens on the first step: not timed
            raise RuntimeError("libcosim failed to initialize")
        started = time.perf_counter()
        ok = execution.step(chain.steps - 1)
        seconds = time.perf_counter() - started
        if not ok:
            raise RuntimeError("libcosim step failed")
        del execution, slaves
        return Sample(seconds, chain.steps - 1, final)

    return run_once


#: Contenders in table order; the floor comes first as the reference.
CONTENDERS: dict[str, Prepare] = {
    CTYPES_FLOOR: prepare_ctypes_floor,
    FMIONNX: prepare_fmionnx,
    FMIONNX_PYTHON: prepare_fmionnx_python,
    FMPY_LOOP: prepare_fmpy_loop,
    SIMULATE_FMU: prepare_simulate_fmu,
    LIBCOSIM: prepare_libcosim,
}


# -- measuring -----------------------------------------------------------------------------------


@dataclass
class Outcome:
    """All repetitions of one contender on one chain (or why it did not run)."""

    contender: str
    n: int
    samples: list[Sample] = field(default_factory=list)
    skipped: str | None = None
    expected: float = 0.0

    @property
    def median_us(self) -> float:
        """Median microseconds per chain step."""
        return statistics.median(s.per_step for s in self.samples) * 1e6

    @property
    def min_us(self) -> float:
        """Fastest repetition, microseconds per chain step."""
        return min(s.per_step for s in self.samples) * 1e6

    @property
    def correct(self) -> bool:
        """Every repetition ended with the tail output ``2**n``."""
        return bool(self.samples) and all(s.final == self.expected for s in self.samples)


def measure(chain: Chain, repeats: int, names: list[str] | None = None) -> list[Outcome]:
    """Prepare every contender, then run ``repeats`` interleaved rounds (rotating order)."""
    chosen = names or list(CONTENDERS)
    outcomes = {name: Outcome(name, chain.n, expected=chain.expected) for name in chosen}
    runners: dict[str, RunOnce] = {}
    for name in chosen:
        prepared = CONTENDERS[name](chain)
        if isinstance(prepared, str):
            outcomes[name].skipped = prepared
        else:
            runners[name] = prepared
    order = list(runners)
    for round_ in range(repeats):
        shift = round_ % len(order) if order else 0
        for name in order[shift:] + order[:shift]:
            outcomes[name].samples.append(runners[name]())
    return [outcomes[name] for name in chosen]


def run(
    sizes: tuple[int, ...] = (1, 10, 50),
    steps: int = 10_000,
    repeats: int = 5,
    names: list[str] | None = None,
    work: Path | None = None,
) -> list[Outcome]:
    """The whole benchmark: every size, every contender; the Gain FMU built once."""
    folder = work or Path(tempfile.mkdtemp(prefix="fmionnx-bench-"))
    folder.mkdir(parents=True, exist_ok=True)
    outcomes: list[Outcome] = []
    try:
        with built_gain(folder) as (fmu, unzipped):
            for n in sizes:
                outcomes.extend(measure(Chain(fmu, unzipped, n, steps), repeats, names))
    finally:
        if work is None:
            shutil.rmtree(folder, ignore_errors=True)
    return outcomes
