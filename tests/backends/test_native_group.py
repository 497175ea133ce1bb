"""The native FMI 2 group kernel: used where it applies, bit-identical to the Python path.

Every comparison runs the same system twice, natively and with ``FMIONNX_NATIVE=0``, and
compares the recorded signals byte for byte (NaN included), the fault text and the number of
steps done. How the library is found, checked and refused: ``test_native_kernel.py``.
"""

from __future__ import annotations

import json
import logging
import re
from pathlib import Path

import pytest

import fmionnx
from fmionnx.results import write_results
from fmionnx.runtime.result import RunResult, RunStatus


@pytest.fixture(scope="module")
def native_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One cache for the module's opt-in builds, outside the user's cache."""
    return tmp_path_factory.mktemp("native-cache")


@pytest.fixture(autouse=True)
def _isolated_cache(monkeypatch: pytest.MonkeyPatch, native_cache: Path) -> None:
    monkeypatch.setenv("FMIONNX_CACHE", str(native_cache))
    monkeypatch.delenv("FMIONNX_NATIVE", raising=False)
    monkeypatch.delenv("FMIONNX_CC", raising=False)


def _gain_chain(fixture_fmu, write_system, n: int = 3) -> Path:
    gain = fixture_fmu("Gain")
    lines = [
        "fmionnx: 1",
        "name: gains",
        "run: {stop: 0.05, step: 0.01}",
        "components:",
        f"  g0: {{kind: fmu, path: {gain}, parameters: {{u: 1.0}}}}",
        *(f"  g{i}: {{kind: fmu, path: {gain}}}" for i in range(1, n)),
        "connections:",
        *(f"  - g{i - 1}.y -> g{i}.u" for i in range(1, n)),
        f"record: [g{n - 1}.y]",
    ]
    return write_system("\n".join(lines) + "\n")


def _multi_rate(fixture_fmu, write_system) -> Path:
    """Two rates, scaled and array connections, held slow values and a cut feedback loop."""
    gain, integrator = fixture_fmu("Gain"), fixture_fmu("Integrator")
    return write_system(
        f"""
fmionnx: 1
name: multi_rate
run: {{stop: 0.6, step: 0.01}}
components:
  src: {{kind: fmu, path: {gain}, parameters: {{k: 1.3, v: [0.1, 0.2, 0.3]}}}}
  g1: {{kind: fmu, path: {gain}, parameters: {{k: 0.9}}}}
  slow: {{kind: fmu, path: {integrator}, period: 0.03, parameters: {{x0: 0.25}}}}
  g2: {{kind: fmu, path: {gain}, parameters: {{k: 1.1}}}}
  fast: {{kind: fmu, path: {integrator}}}
connections:
  - {{from: src.y, to: g1.u, factor: 0.1, offset: 0.3}}
  - src.w -> g1.v
  - {{from: 'g1.w[2]', to: slow.u, factor: 3.7, offset: -0.11}}
  - slow.x -> g2.u
  - g1.y -> g2.v[1]
  - g2.y -> fast.u
  - {{from: fast.x, to: src.u, factor: -0.5, offset: 0.7}}
record: [src.u, src.y, g1.v, g1.w, slow.u, slow.x, g2.u, g2.v, g2.y, fast.x]
"""
    )


def _faulty_group(fixture_fmu, write_system, mode: int) -> Path:
    gain, faulty = fixture_fmu("Gain"), fixture_fmu("Faulty")
    return write_system(
        f"""
fmionnx: 1
name: faulty_group
run: {{stop: 1.0, step: 0.01}}
components:
  head: {{kind: fmu, path: {gain}, parameters: {{u: 0.5}}}}
  bad: {{kind: fmu, path: {faulty}, parameters: {{mode: {mode}, failAt: 0.3}}}}
  tail: {{kind: fmu, path: {gain}}}
connections:
  - head.y -> bad.u
  - bad.y -> tail.u
record: [head.y, bad.u, bad.y, tail.u, tail.y]
"""
    )


def _both_ways(
    path: Path, monkeypatch: pytest.MonkeyPatch, setting: str = "1"
) -> tuple[RunResult, RunResult]:
    with monkeypatch.context() as patch:
        patch.setenv("FMIONNX_NATIVE", setting)
        native = fmionnx.load(path).run(isolate="none")
    with monkeypatch.context() as patch:
        patch.setenv("FMIONNX_NATIVE", "0")
        python = fmionnx.load(path).run(isolate="none")
    return native, python


def _assert_bit_identical(native: RunResult, python: RunResult) -> None:
    assert native.steps_done == python.steps_done
    assert list(native.signals) == list(python.signals)
    for name, values in python.signals.items():
        assert native.signals[name].tobytes() == values.tobytes(), name


def test_gain_chain_is_stepped_by_one_native_group(fixture_fmu, write_system) -> None:
    result = fmionnx.load(_gain_chain(fixture_fmu, write_system, n=3)).run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    sha256 = result.details.pop("native_sha256")
    assert re.fullmatch(r"[0-9a-f]{64}", str(sha256))
    assert result.details == {
        "native": True,
        "native_reason": None,
        "native_groups": 1,
        "native_components": 3,
        "native_library": "installed",
        "native_loop": True,
        "schedule": "parallel",
        "concurrent": None,
        "concurrent_steps": 0,
        "isolate": "none",
        "isolate_default": False,
    }
    assert result["g2.y"][-1] == 8.0


@pytest.mark.parametrize(("setting", "library"), [("1", "installed"), ("build", "build")])
def test_multi_rate_system_is_bit_identical_natively_and_in_python(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, setting: str, library: str
) -> None:
    path = _multi_rate(fixture_fmu, write_system)
    native, python = _both_ways(path, monkeypatch, setting)
    assert native.details["native_library"] == library
    assert native.status is python.status is RunStatus.COMPLETED
    # src+g1 | slow (other rate) | g2+fast
    assert native.details["native_groups"] == 3
    assert native.details["native_components"] == 5
    assert python.details["native"] is False
    assert python.details["native_reason"] == "disabled by FMIONNX_NATIVE=0"
    _assert_bit_identical(native, python)
    assert len(set(native["slow.x"].tolist())) > 10  # the signals really move


@pytest.mark.parametrize(
    ("mode", "message", "steps"),
    [
        (0, r"^component `bad` at t=0\.3 s: fmi2DoStep returned Error$", 30),
        (2, r"^component `bad` at t=0\.3 s: fmi2DoStep returned Discard$", 30),
        # the step from 0.29 reaches failAt and publishes NaN; tail's transfer stops the run
        (
            1,
            r"^component `bad`, port `y` at t=0\.29 s: NaN on the connection `bad\.y -> tail\.u`$",
            29,
        ),
    ],
)
def test_fault_inside_a_group_matches_the_python_path(
    fixture_fmu,
    write_system,
    monkeypatch: pytest.MonkeyPatch,
    mode: int,
    message: str,
    steps: int,
) -> None:
    native, python = _both_ways(_faulty_group(fixture_fmu, write_system, mode), monkeypatch)
    assert native.details["native_components"] == 3
    assert native.status is python.status is RunStatus.FAULT
    assert native.error is not None
    assert python.error is not None
    assert str(native.error) == str(python.error)
    assert (native.error.component, native.error.port, native.error.time) == (
        python.error.component,
        python.error.port,
        python.error.time,
    )
    with pytest.raises(type(native.error), match=message):
        raise native.error
    assert native.steps_done == steps
    _assert_bit_identical(native, python)


@pytest.mark.parametrize(
    ("compiler", "reason"),
    [
        ("no-such-compiler-fmionnx", r"`no-such-compiler-fmionnx` not found"),
        ("false", r"`false` failed \(exit 1\)"),
    ],
)
def test_run_falls_back_to_python_when_the_opt_in_build_fails(
    fixture_fmu,
    write_system,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    compiler: str,
    reason: str,
) -> None:
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "empty-cache"))
    monkeypatch.setenv("FMIONNX_NATIVE", "build")
    monkeypatch.setenv("FMIONNX_CC", compiler)
    system = fmionnx.load(_gain_chain(fixture_fmu, write_system, n=3))
    with caplog.at_level(logging.DEBUG, logger="fmionnx.runtime.native"):
        result = system.run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    assert result["g2.y"][-1] == 8.0
    assert result.details["native"] is False
    assert result.details["native_components"] == 0
    assert result.details["native_library"] is None
    assert re.search(reason, str(result.details["native_reason"]))
    assert any("native kernel not used" in r.getMessage() for r in caplog.records)
    write_results(result, system.compiled, tmp_path / "out")
    execution = json.loads((tmp_path / "out" / "run.json").read_text())["execution"]
    assert execution["native"] is False
    assert execution["native_reason"] == result.details["native_reason"]
    assert not any((tmp_path / "empty-cache").rglob("*.so"))


def test_model_exchange_fmus_stay_in_the_python_path(fixture_fmu, write_system) -> None:
    gain, integrator = fixture_fmu("Gain"), fixture_fmu("Integrator")
    path = write_system(
        f"""
fmionnx: 1
name: mixed
run: {{stop: 0.1, step: 0.01}}
components:
  gain: {{kind: fmu, path: {gain}, parameters: {{u: 1.5}}}}
  integ: {{kind: fmu, path: {integrator}, interface: me}}
connections:
  - gain.y -> integ.u
"""
    )
    result = fmionnx.load(path).run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    assert (result.details["native_groups"], result.details["native_components"]) == (1, 1)
