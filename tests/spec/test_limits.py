"""Resource limits of the YAML front end and range checks of the numbers a system file holds.

Every input here once hung ``fmionnx validate``, grew past gigabytes or ended in a traceback.
Each test asserts the diagnostic (code and position) that replaces it, so a protection that
breaks fails the test instead of hanging it for long: the inputs are sized so that without
the limit they would take far longer than the whole suite.
"""

from __future__ import annotations

import shutil
import signal
import sys
from collections.abc import Iterator
from pathlib import Path
from types import FrameType

import pytest
from typer.testing import CliRunner

from fmionnx.api import compile_system
from fmionnx.cli.app import app
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.core.types import DType
from fmionnx.spec.limits import MAX_ALIAS_NODES, MAX_DEPTH, MAX_DOCUMENT_BYTES, check_limits
from tests.conftest import build_fixture_fmu

HEAD = "fmionnx: 1\nname: limits\n"
GAIN = "components:\n  gain: {kind: fmu, path: Gain.fmu}\n"


#: Seconds any test here may take: with the limits each takes well under one.
DEADLINE = 30


@pytest.fixture(autouse=True)
def deadline() -> Iterator[None]:
    """Fail (instead of hanging the suite) when a protection broke and an input runs away."""
    if not hasattr(signal, "SIGALRM"):  # pragma: no cover - Windows: no guard
        yield
        return

    def expired(signum: int, frame: FrameType | None) -> None:
        pytest.fail(f"took more than {DEADLINE} s: a resource limit no longer holds")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.alarm(DEADLINE)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    """A folder with Gain.fmu (float64 parameter `k`, inputs `u`, `v`)."""
    shutil.copy(build_fixture_fmu("Gain"), tmp_path / "Gain.fmu")
    return tmp_path


def errors(path: Path) -> list[Diagnostic]:
    result = compile_system(path)
    return [d for d in result.diagnostics if d.severity.label == "error"]


def only_error(path: Path) -> Diagnostic:
    found = errors(path)
    assert len(found) == 1, [str(d.message) for d in found]
    return found[0]


def where(diagnostic: Diagnostic) -> tuple[int, int]:
    assert diagnostic.span is not None
    return diagnostic.span.line, diagnostic.span.col


def bomb(levels: int, width: int = 10) -> str:
    """A "billion laughs" document: ``width**levels`` strings once the aliases expand."""
    lines = ["a0: &a0 [" + ", ".join(["lol"] * width) + "]"]
    lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


# -- alias expansion ---------------------------------------------------------------------------


def test_alias_bomb_in_a_system_file_is_refused_at_the_alias_that_crosses_the_limit(
    tmp_path: Path,
) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(HEAD + bomb(12) + GAIN, encoding="utf-8")  # 10**12 nodes expanded
    diagnostic = only_error(path)
    assert diagnostic.code == "E003"
    assert f"more than {MAX_ALIAS_NODES} nodes" in diagnostic.message
    # a3 repeats a2 (1111 nodes): the 9th alias of line 6 passes 10 000 (col of its `*`)
    assert where(diagnostic) == (6, 45)


def test_merge_keys_count_as_aliases(tmp_path: Path) -> None:
    lines = ["m0: &m0 {" + ", ".join(f"k{j}: x" for j in range(10)) + "}"]
    for i in range(1, 8):
        refs = ", ".join(f"k{j}: *m{i - 1}" for j in range(10))
        lines.append(f"m{i}: &m{i} {{<<: *m{i - 1}, {refs}}}")
    path = tmp_path / "system.yaml"
    path.write_text(HEAD + "\n".join(lines) + "\n" + GAIN, encoding="utf-8")
    diagnostic = only_error(path)
    assert diagnostic.code == "E003"
    assert "aliases expand" in diagnostic.message


def test_a_few_aliases_still_work(folder: Path) -> None:
    path = folder / "system.yaml"
    path.write_text(
        HEAD + "run: &run {stop: 1, step: 0.01}\n"
        "components:\n  gain: {kind: fmu, path: Gain.fmu, parameters: {k: &k 2.5, u: *k}}\n",
        encoding="utf-8",
    )
    assert errors(path) == []


def test_alias_bomb_through_the_cli_returns_promptly(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(HEAD + bomb(30, width=2) + GAIN, encoding="utf-8")  # 2**30 strings
    result = CliRunner().invoke(app, ["validate", str(path)], catch_exceptions=False)
    assert result.exit_code == 1
    assert "error[E003 invalid-value]" in result.output
    assert "aliases expand to more than" in result.output


# -- nesting -----------------------------------------------------------------------------------


@pytest.mark.parametrize("depth", [MAX_DEPTH + 1, 100_000])
def test_deep_flow_nesting_is_refused_without_recursion_error(tmp_path: Path, depth: int) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(HEAD + "x: " + "[" * depth + "\n" + GAIN, encoding="utf-8")
    diagnostic = only_error(path)
    assert diagnostic.code == "E003"
    assert f"more than {MAX_DEPTH} levels" in diagnostic.message
    # the top-level map is level 1, so the 100th `[` (the first is in column 4) opens level 101
    assert where(diagnostic) == (3, 4 + MAX_DEPTH - 1)


def test_deep_block_nesting_is_refused(tmp_path: Path) -> None:
    text = "".join(f"{'  ' * i}k{i}:\n" for i in range(MAX_DEPTH + 5))
    path = tmp_path / "system.yaml"
    path.write_text(HEAD + text, encoding="utf-8")
    diagnostic = only_error(path)
    assert diagnostic.code == "E003"
    assert "levels deep" in diagnostic.message


def test_nesting_up_to_the_limit_passes_the_limit_check() -> None:
    text = "x: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1) + "\n"
    bag = DiagnosticBag()
    assert check_limits(text, Path("system.yaml"), bag)
    assert list(bag) == []


# -- size --------------------------------------------------------------------------------------


def test_oversized_document_is_refused_at_its_start(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    with path.open("w", encoding="utf-8") as stream:
        stream.write(HEAD + GAIN + "# ")
        stream.write("x" * (MAX_DOCUMENT_BYTES - stream.tell() + 1) + "\n")
    diagnostic = only_error(path)
    assert diagnostic.code == "E003"
    assert f"more than the {MAX_DOCUMENT_BYTES} bytes" in diagnostic.message
    assert where(diagnostic) == (1, 1)


# -- numbers in the system file ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("literal", "shown"),
    [
        ("1e400", "`1e400`"),
        ("-1e400", "`-1e400`"),
        ("1" * 5000, "(5000 characters)"),
        ("0x" + "f" * 300, "(302 characters)"),
    ],
)
def test_number_beyond_float_range_is_e003_where_it_is_written(
    folder: Path, literal: str, shown: str
) -> None:
    path = folder / "system.yaml"
    path.write_text(
        HEAD + "run: {stop: 1, step: 0.01}\n"
        f"components:\n  gain:\n    kind: fmu\n    path: Gain.fmu\n    parameters: {{k: {literal}}}\n",
        encoding="utf-8",
    )
    diagnostic = only_error(path)
    assert diagnostic.code == "E003"
    assert "beyond the range of a 64-bit float" in diagnostic.message
    assert shown in diagnostic.message
    assert where(diagnostic) == (8, 21)


def test_quoted_long_digits_stay_a_string(tmp_path: Path) -> None:
    bag = DiagnosticBag()
    assert check_limits(f'x: "{"9" * 5000}"\n', tmp_path / "s.yaml", bag)


@pytest.mark.parametrize(
    ("run", "code", "fragment", "col"),
    [
        ("{stop: 1, step: 5e-324}", "E003", "normal positive float", 22),
        ("{stop: 1e308, start: -1e308, step: 0.01}", "E040", "longer than the largest float", 13),
        ("{stop: 1e300, step: 1e-300}", "E040", "more than 2**53 base steps", 26),
    ],
)
def test_run_settings_out_of_range(
    folder: Path, run: str, code: str, fragment: str, col: int
) -> None:
    path = folder / "system.yaml"
    path.write_text(HEAD + f"run: {run}\n" + GAIN, encoding="utf-8")
    diagnostic = only_error(path)
    assert diagnostic.code == code
    assert fragment in diagnostic.message
    assert where(diagnostic) == (3, col)


def test_smallest_normal_step_is_accepted_by_the_schema(folder: Path) -> None:
    path = folder / "system.yaml"
    path.write_text(
        HEAD + f"run: {{stop: {sys.float_info.min * 4!r}, step: {sys.float_info.min!r}}}\n" + GAIN,
        encoding="utf-8",
    )
    assert errors(path) == []


def test_huge_period_is_e041_before_the_run(folder: Path) -> None:
    path = folder / "system.yaml"
    path.write_text(
        HEAD + "run: {stop: 1, step: 0.01}\n"
        "components:\n  gain: {kind: fmu, path: Gain.fmu, period: 1e300}\n",
        encoding="utf-8",
    )
    diagnostic = only_error(path)
    assert diagnostic.code == "E041"
    assert "2**53" in diagnostic.message
    assert where(diagnostic) == (5, 45)


@pytest.mark.parametrize(
    ("dtype", "value", "problem"),
    [
        (DType.INT8, 128, "outside the range of int8 (-128 to 127)"),
        (DType.UINT8, -1, "outside the range of uint8"),
        (DType.INT64, 2**63, "outside the range of int64"),
        (DType.FLOAT64, 10**400, "beyond the range of float64"),
        (DType.FLOAT32, 1e39, "beyond the range of float32"),
        (DType.FLOAT32, 10**39, "beyond the range of float32"),
    ],
)
def test_out_of_range_values_per_type(dtype: DType, value: float, problem: str) -> None:
    assert problem in (dtype.out_of_range(value) or "")


@pytest.mark.parametrize(
    ("dtype", "value"),
    [(DType.INT8, -128), (DType.UINT64, 2**64 - 1), (DType.FLOAT64, 1e308),
     (DType.FLOAT64, float("inf")), (DType.BOOL, True), (DType.STRING, "x")],
)  # fmt: skip
def test_in_range_values_per_type(dtype: DType, value: object) -> None:
    assert dtype.out_of_range(value) is None


# -- step counts -------------------------------------------------------------------------------


def test_validate_warns_about_a_very_long_run(folder: Path) -> None:
    path = folder / "system.yaml"
    path.write_text(HEAD + "run: {stop: 1e7, step: 0.01}\n" + GAIN, encoding="utf-8")
    result = compile_system(path)
    assert result.ok
    long_runs = [d for d in result.diagnostics if d.code == "W040"]
    assert len(long_runs) == 1
    assert "1e+09 base steps" in long_runs[0].message
    assert where(long_runs[0]) == (3, 24)


def test_a_run_of_ordinary_length_does_not_warn(folder: Path) -> None:
    path = folder / "system.yaml"
    path.write_text(HEAD + "run: {stop: 1e6, step: 0.01}\n" + GAIN, encoding="utf-8")
    assert [d for d in compile_system(path).diagnostics if d.code == "W040"] == []
