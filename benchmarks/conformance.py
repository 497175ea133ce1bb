"""Conformance cases of issue #33, measured on the tools that install here: fmionnx, FMPy, libcosim.

Usage: ``python benchmarks/conformance.py`` (after ``make setup-test``; it builds the test
FMUs it needs from ``tests/fixtures/fmus``). Prints one Markdown table row per case and tool:
what the tool did with the case, as run here, not as its documentation says. OMSimulator and
Ecos do not install here; ``docs/comparison.md`` quotes the issue's own OMSimulator run for them.

Cases: model exchange of the event fixtures (discrete inputs: Feedthrough; state events:
BouncingBall; time events and a terminal event: Stair), FMI 2 and FMI 3; and the SSP
parameter cases (a connected parameter connector against a direct binding, in an ``.ssv``
file and inline; a bound top-level connector connected to nothing).
"""

from __future__ import annotations

import functools
import multiprocessing
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from tests.conftest import build_fixture_fmu  # noqa: E402


def _attempt(call: Callable[[], str]) -> str:
    try:
        return call()
    except Exception as exc:  # a tool's refusal is the measurement
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return f"fails: {text[:110]}"


def _child(call: Callable[[], str], queue: multiprocessing.Queue[str]) -> None:
    queue.put(_attempt(call))


def _outcome(call: Callable[[], str]) -> str:
    """``call()`` in a child process: a tool that crashes is measured, not fatal here."""
    context = multiprocessing.get_context("fork")
    queue: multiprocessing.Queue[str] = context.Queue()
    process = context.Process(target=_child, args=(call, queue))
    process.start()
    process.join(120)
    if process.is_alive():
        process.kill()
        process.join()
        return "hangs (killed after 120 s)"
    if process.exitcode != 0:
        return f"crashes (exit code {process.exitcode})"
    return queue.get()


def _fmionnx_me(fmu: Path, name: str, stop: float, step: float) -> str:
    import fmionnx

    result = fmionnx.load(fmu, interface="me", step=step).run(stop_time=stop)
    last = result[name][-1]
    return f"{result.status}, last row t={result.time[-1]:g} {name}={last:g}"


def _fmpy_me(fmu: Path, name: str, stop: float, step: float) -> str:
    from fmpy import simulate_fmu

    result = simulate_fmu(
        str(fmu),
        fmi_type="ModelExchange",
        stop_time=stop,
        output_interval=step,
        output=[name],
        record_events=False,
    )
    return f"runs, last row t={result['time'][-1]:g} {name}={result[name][-1]:g}"


def _libcosim(fmu: Path, name: str, stop: float, step: float) -> str:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(step_size=int(step * 1e9))
    index = execution.add_local_slave(CosimLocalSlave(fmu_path=str(fmu), instance_name="m"))
    if index < 0:
        return "refuses the FMU (co-simulation only: no model exchange)"
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)
    execution.simulate_until(int(stop * 1e9))
    variable = next(v for v in execution.slave_variables(index) if v.name == name.encode())
    if variable.type == 0:
        (value,) = observer.last_real_values(index, [variable.reference])
    else:
        (value,) = observer.last_integer_values(index, [variable.reference])
    return f"co-simulation only; its CS run: {name}={value:g}"


FMU_CASES = (
    ("Feedthrough", "Float64_discrete_output", 2.0, 0.5),
    ("BouncingBall", "h", 3.0, 0.01),
    ("Stair", "counter", 10.0, 0.2),
)


def _ssp_cases(folder: Path) -> list[tuple[str, Path, str]]:
    """The precedence archives of tests/ssp/test_parameter_precedence.py."""
    from tests.ssp import test_parameter_precedence as precedence

    archives = precedence.archives.__wrapped__(folder, build_fixture_fmu)  # type: ignore[attr-defined]
    return [
        ("parameter connector vs direct binding, .ssv", archives["ssv"], "inner.addP.y"),
        ("parameter connector vs direct binding, inline", archives["inline"], "inner.addP.y"),
    ]


def _fmionnx_ssp(path: Path, name: str) -> str:
    import fmionnx

    result = fmionnx.load(path).run()
    return f"{name} = {result[name][-1]:g}"


def _fmpy_ssp(path: Path, name: str) -> str:
    from fmpy.ssp.simulation import simulate_ssp

    result = simulate_ssp(str(path), stop_time=0.1, step_size=0.05)
    return f"{name} = {result[name][-1]:g}"


def _libcosim_ssp(path: Path, name: str) -> str:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_ssp_file(str(path), step_size=50_000_000)
    return "loads" if execution is not None else "refuses"


def main() -> None:
    print("| case | FMI | fmionnx | FMPy | libcosim |")
    print("|---|---|---|---|---|")
    for model, name, stop, step in FMU_CASES:
        for version in ("2", "3"):
            fmu = build_fixture_fmu(f"{model}{version}")
            cells = [
                _outcome(functools.partial(tool, fmu, name, stop, step))
                for tool in (_fmionnx_me, _fmpy_me, _libcosim)
            ]
            print(f"| {model} ME | {version}.0 | " + " | ".join(cells) + " |")
    with tempfile.TemporaryDirectory() as scratch:
        for label, path, name in _ssp_cases(Path(scratch)):
            cells = [
                _outcome(lambda p=path, n=name: _fmionnx_ssp(p, n)),
                _outcome(lambda p=path, n=name: _fmpy_ssp(p, n)),
                _outcome(lambda p=path: _libcosim_ssp(p, "")),
            ]
            print(f"| {label} | 2.0 | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
