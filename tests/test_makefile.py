"""``make demo`` installs what the demo needs, ``make test`` what the tests need (issue #16).

The Makefile runs in a scratch folder where every program it calls (the venv's python, pip,
fmionnx, ruff, mypy, pytest, the system-deps script) is a stub that logs its arguments, so
the test sees which set of extras each command installs and that nothing is installed twice.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

STUB = """#!/bin/sh
echo "$(basename "$0") $*" >> "{log}"
"""

INSTALL_INPUTS = (
    "pyproject.toml",
    "setup.py",
    "fmionnx/runtime/native/fmi2_group.c",
    "fmionnx/runtime/native/manifest.py",
)


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    shutil.copy(REPO / "Makefile", tmp_path / "Makefile")
    for name in INSTALL_INPUTS:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("", encoding="utf-8")
    (tmp_path / "tools").mkdir()
    (tmp_path / "tools" / "system-deps.sh").write_text("true\n", encoding="utf-8")
    bin_dir = tmp_path / ".venv" / "bin"
    bin_dir.mkdir(parents=True)
    for program in ("python", "fmionnx", "ruff", "mypy", "pytest"):
        (bin_dir / program).write_text(STUB.format(log=tmp_path / "log"), encoding="utf-8")
        (bin_dir / program).chmod(0o755)
    return tmp_path


def make(tree: Path, *targets: str) -> list[str]:
    """The programs ``make TARGETS`` ran (one line each), the log emptied for the next call."""
    subprocess.run(["make", "-s", *targets], cwd=tree, check=True, capture_output=True)
    log = tree / "log"
    lines = log.read_text(encoding="utf-8").splitlines() if log.exists() else []
    log.unlink(missing_ok=True)
    return lines


def installs(lines: list[str]) -> list[str]:
    return [line for line in lines if " -m pip install " in line and "--upgrade pip" not in line]


def test_demo_installs_the_package_without_the_test_extras(tree: Path) -> None:
    lines = make(tree, "demo")
    assert installs(lines) == ["python -m pip install --quiet -e ."]
    assert lines[-1] == "fmionnx run systems/sign_follower.yaml --out out/demo"
    assert not any("[test]" in line or "pytest" in line for line in lines)


SUITE = "pytest -q -p no:cacheprovider -n 2 --dist loadscope -m not slow --durations=30"


def test_test_installs_the_test_extras_once_and_runs_the_suite(tree: Path) -> None:
    lines = make(tree, "test")
    assert [line for line in installs(lines) if "lark==" not in line] == [
        "python -m pip install --quiet -e .[test]"
    ]
    # on both cores of a CI machine; CI logs its slowest tests
    assert lines[-1] == SUITE


def test_the_test_set_includes_the_demo_set(tree: Path) -> None:
    make(tree, "test")
    assert installs(make(tree, "demo")) == []


def test_after_the_demo_the_tests_add_their_extras_and_nothing_reinstalls_later(
    tree: Path,
) -> None:
    make(tree, "demo")
    assert "python -m pip install --quiet -e .[test]" in installs(make(tree, "test"))
    assert installs(make(tree, "test")) == []
    assert installs(make(tree, "demo")) == []


def test_ci_runs_make_test_only() -> None:
    script = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    commands = [
        line.strip()
        for line in script.splitlines()
        if line.strip() and not line.lstrip().startswith("#")
    ]
    assert commands[-1] == "make test"
    assert not any(c.startswith("make ") and c != "make test" for c in commands)


def test_test_lints_and_runs_the_examples_before_the_suite(tree: Path) -> None:
    lines = make(tree, "test")
    assert "ruff check fmionnx tests models benchmarks examples tools" in lines
    format_check = (
        "ruff format --check fmionnx tests models benchmarks examples tools docs README.md"
    )
    assert format_check in lines  # the Python blocks of the docs too
    assert "mypy examples" in lines
    assert lines.index("python examples/run_all.py") < lines.index(SUITE)


def test_examples_need_the_demo_set_only(tree: Path) -> None:
    lines = make(tree, "examples")
    assert installs(lines) == ["python -m pip install --quiet -e ."]
    assert lines[-1] == "python examples/run_all.py"


WARNING_PROBE = """
import warnings
warnings.warn(
    "Editable installation.\\n!!\\n\\n    Please be careful with folders in your working directory "
    "with the same\\n    name as your package as they may take precedence during imports.\\n!!",
    UserWarning,
)
warnings.warn("another warning", UserWarning)
"""


def test_installs_silence_setuptools_editable_warning_box_and_nothing_else(tree: Path) -> None:
    """``make demo`` printed setuptools' boxed "Editable installation" warning (issue #34)."""
    stub = tree / ".venv" / "bin" / "python"
    log = tree / "log"
    stub.write_text(
        f'#!/bin/sh\necho "$(basename "$0") $* PYTHONWARNINGS=$PYTHONWARNINGS" >> "{log}"\n',
        encoding="utf-8",
    )
    lines = [*installs(make(tree, "demo")), *installs(make(tree, "test"))]
    assert len([line for line in lines if "-e " in line]) == 2
    filters = {line.partition(" PYTHONWARNINGS=")[2] for line in lines if "-e " in line}
    (value,) = filters
    assert value
    probe = subprocess.run(
        [sys.executable, "-c", WARNING_PROBE],
        env={**os.environ, "PYTHONWARNINGS": value},
        capture_output=True,
        text=True,
        check=True,
    )
    assert "Editable installation" not in probe.stderr
    assert "another warning" in probe.stderr
