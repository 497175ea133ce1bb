"""Smoke test of ``benchmarks/native_reach.py``: every chain runs both ways, natively in one
group, to bit-identical results, and the table is printed. Times are never asserted."""

from __future__ import annotations

import io

from rich.console import Console

from benchmarks import native_reach


def test_every_chain_runs_natively_and_in_python_to_the_same_results() -> None:
    text = io.StringIO()
    results = native_reach.main(["--quick"], Console(file=text, width=200))
    rows = results["rows"]
    assert [r["case"] for r in rows] == [case.label for case in native_reach.CASES]
    for row in rows:
        assert row["identical"], row["case"]
        assert (row["native_groups"], row["native_components"]) == (1, 3), row["case"]
        assert row["native_us"] > 0
        assert row["python_us"] > 0
    printed = text.getvalue()
    assert "Chains of 3 FMUs" in printed
    assert "FMI 3, 11 types (Types3)" in printed
