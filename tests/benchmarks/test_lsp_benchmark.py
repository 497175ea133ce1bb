"""The language-server benchmark runs end to end in its quick form and prints its table."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import REPO


def test_quick_run_times_refreshes_and_validate_side_by_side() -> None:
    done = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "lsp.py"), "--quick"],
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "refresh after an edit, median of 2" in done.stdout
    assert "`fmionnx validate` from the shell, median of 1" in done.stdout
    assert "refresh / validate" in done.stdout


#: A benchmark's quick run: `make soak` runs it, `make test` does not (docs/contributing.md).
pytestmark = pytest.mark.slow
