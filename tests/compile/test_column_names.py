"""The results' column names of a port: one per element, indexed as a system file writes it."""

from __future__ import annotations

import pytest

from fmionnx.core.signals import column_names
from fmionnx.core.types import Causality, DType, Port


def _port(shape: tuple[int | str, ...]) -> Port:
    return Port("x", Causality.OUTPUT, DType.FLOAT64, shape)


def test_a_scalar_is_one_column() -> None:
    assert column_names("c", _port(())) == ["c.x"]


def test_a_matrix_is_indexed_row_by_row() -> None:
    assert column_names("c", _port((2, 2))) == ["c.x[0,0]", "c.x[0,1]", "c.x[1,0]", "c.x[1,1]"]


@pytest.mark.parametrize("shape", [(0,), (2, 0), (0, 3)])
def test_an_array_of_no_elements_has_no_column(shape: tuple[int, ...]) -> None:
    """FMI 3 lets a dimension be 0; such a port was given one column (``(0,)``) or made the
    index arithmetic divide by zero (``(2, 0)``)."""
    assert column_names("c", _port(shape)) == []


def test_a_symbolic_dimension_stands_as_one_column() -> None:
    assert column_names("c", _port(("n",))) == ["c.x[0]"]
