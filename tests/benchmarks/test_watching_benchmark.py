"""Smoke test of ``benchmarks/watching.py``: every loop runs, the profiled ones against their
plain loop, and ``--against`` measures another tree's fmionnx in its own worker (the worker
refuses to report a tree other than the one it was given). Times are never asserted."""

from __future__ import annotations

import io
import subprocess

import pytest
from rich.console import Console

from benchmarks import watching

#: A benchmark's quick run: `make soak` runs it, `make test` does not (docs/contributing.md).
pytestmark = pytest.mark.slow


def test_the_loops_and_another_tree_are_measured_side_by_side() -> None:
    inside = subprocess.run(
        ["git", "-C", str(watching.REPO), "rev-parse", "HEAD"], capture_output=True, text=True,
        check=False,
    )  # fmt: skip
    if inside.returncode != 0:
        pytest.skip("not a git checkout: --against exports a revision with git archive")
    text = io.StringIO()
    results = watching.main(["--quick", "--against", "HEAD"], Console(file=text, width=250))
    rows = {row["contender"]: row for row in results["this_tree"]}
    assert list(rows) == [watching.CTYPES_FLOOR, *watching.FMIONNX_LOOPS]
    assert rows[watching.CTYPES_FLOOR]["vs_floor"] == 1
    for name in watching.FMIONNX_LOOPS:
        assert rows[name]["median_us_per_step"] > 0
        assert rows[name]["vs_plain"] > 0
    assert rows[watching.PLAIN]["vs_plain"] == rows[watching.PLAIN_PYTHON]["vs_plain"] == 1
    against = results["against"]["rows"]
    assert [row["contender"] for row in against] == list(watching.UNASKED)
    for row in against:
        assert row["before_vs_floor"] > 0
        assert row["after_vs_floor"] > 0
    printed = text.getvalue()
    assert "this tree against HEAD" in printed
    assert "fmionnx --profile, Python path" in printed
