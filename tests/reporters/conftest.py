"""Hand-made results for reporter unit tests: two system files, errors, warnings, an info."""

from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.diagnostics import Note, Span, make
from fmionnx.reporters import FileResult


@pytest.fixture
def two_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> list[FileResult]:
    """Results of ``validate a.yaml sub/b.yaml`` run in ``tmp_path``."""
    monkeypatch.chdir(tmp_path)
    a = tmp_path / "a.yaml"
    b = tmp_path / "sub" / "b.yaml"
    model = tmp_path / "models" / "modelDescription.xml"
    first = (
        make(
            codes.DTYPE,
            "cannot connect `net.label_out` (string) to `gain.u` (float64)",
            Span(a, 7, 5),
            hint="connect a numeric output",
            notes=[Note("`u` is declared here", Span(model, 36, 12))],
        ),
        make(
            codes.UNCONNECTED_INPUT,
            "input `gain.v` is not connected; its start value is used",
            Span(a, 5, 3),
        ),
    )
    second = (
        make(codes.UNKNOWN_PORT, "component `plant` has no port `y2`, value: 50%", Span(b, 9, 13)),
        make(codes.FILE_NOT_FOUND, "system file problem without a position", None),
        make(
            codes.LOCK_BINARY_CHANGED,
            "component `plant`: the model file changed, its interface did not",
            Span(b, 4, 3),
        ),
    )
    return [FileResult(a, first), FileResult(b, second)]


@pytest.fixture(scope="session")
def case_models() -> Path:
    """The diagnostics corpus's model folder (real FMUs built from C, a tiny ONNX model)."""
    from tests.cases.conftest import make_case_models

    return make_case_models()
