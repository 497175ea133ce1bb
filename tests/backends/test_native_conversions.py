"""Every conversion the native kernel makes on a connection is the Python transfer's, bit for bit.

For each pair of numeric element types the kernel accepts, identity and scaled connections,
edge values included (signed zeros, subnormals, floats beyond float32, integer extremes,
values that wrap; a non-finite source stops both alike, tested apart), one buffer is filled by the real Python transfer
(:func:`fmionnx.runtime.transfer.make_transfer`) and one by the real kernel
(``fx_group_step`` on a one-member group). The member's ``fmi2DoStep`` is a ctypes callback
standing in for an FMU (a peer: the transfer under test happens before it is called).
"""

from __future__ import annotations

import ctypes
import warnings
from dataclasses import dataclass

import numpy as np
import pytest

from fmionnx.compile.ir import Connection
from fmionnx.core.types import Causality, DType, Port, PortRef
from fmionnx.runtime.native import kernel as k
from fmionnx.runtime.native.group import _fill_transfer
from fmionnx.runtime.transfer import make_transfer

NUMERIC = [name for name, _ in k.ELEMENT_TYPES]

FLOATS = [
    0.0, -0.0, 1.5, -1.5, 0.1, -0.7, 2.5e-310, 1.0e-45, 3.4e38, 3.5e38, -1.0e39, 1.0e300,
    2.0**53 + 2.0, 16777217.0, 255.9, -128.5, 65535.0, 1.0e-8,
]  # fmt: skip
INTEGERS = [
    0, 1, -1, 2, 127, 128, -128, -129, 255, 256, 32767, 32768, -32769, 65535, 65536,
    2**31 - 1, 2**31, -(2**31) - 1, 2**32 + 5, 2**53 + 1, 2**62 + 3, -(2**63), 2**63 - 1,
]  # fmt: skip

#: (factor, offset) of the connections: identity, then two scaled ones.
TRANSFORMS = [(1.0, 0.0), (0.1, 0.3), (-2.5, 0.0)]


def _values(dtype: np.dtype[np.generic]) -> np.ndarray:
    if dtype.kind == "f":
        with np.errstate(over="ignore"):
            values = np.array(FLOATS, dtype=np.float64).astype(dtype)
        return values[np.isfinite(values)]  # beyond float32 a source is infinite: a fault
    if dtype.kind == "b":
        return np.array([v % 3 == 0 for v in range(len(INTEGERS))], dtype=np.bool_)
    wrapped = [v % 2**64 for v in INTEGERS]  # two's complement, as C's conversions wrap
    return np.array(wrapped, dtype=np.uint64).astype(dtype)


@dataclass
class _Peer:
    """Stands in for a runner: only its buffers are read."""

    buffer: np.ndarray

    def output_buffer(self, port: str) -> np.ndarray:
        return self.buffer

    def input_buffer(self, port: str) -> np.ndarray:
        return self.buffer


def _connection(src: np.ndarray, dst: np.ndarray, factor: float, offset: float) -> Connection:
    def port(name: str, causality: Causality, array: np.ndarray) -> Port:
        return Port(name, causality, DType(array.dtype.name), shape=(array.size,))

    return Connection(
        PortRef("a", "y"),
        PortRef("b", "u"),
        port("y", Causality.OUTPUT, src),
        port("u", Causality.INPUT, dst),
        src.size,
        factor,
        offset,
    )


DO_STEP = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int
)


def _native(connection: Connection, src: np.ndarray, dst: np.ndarray) -> int:
    """One group step whose only member has this one incoming connection; the return code."""
    loaded = k.load_installed()
    assert isinstance(loaded, k.Kernel), loaded
    transfers = (k.TransferSpec * 1)()
    _fill_transfer(transfers[0], connection, src, dst)
    do_step = DO_STEP(lambda *_: 0)
    members = (k.Member * 1)()
    members[0].do_step = ctypes.cast(do_step, ctypes.c_void_p).value
    members[0].n_transfers = 1
    calls = (k.CallSpec * 1)()
    group = k.Group(
        1, ctypes.addressof(members), ctypes.addressof(transfers), ctypes.addressof(calls)
    )
    return int(loaded.step(ctypes.addressof(group), 0.0, 0.01))


def _eligible(src: str, dst: str, factor: float, offset: float) -> bool:
    """What grouping.py lets the kernel convert (float into integer stays in Python)."""
    if np.dtype(dst).kind not in "iu":
        return True
    return np.dtype(src).kind != "f" and (factor, offset) == (1.0, 0.0)


CASES = [
    (src, dst, factor, offset)
    for src in NUMERIC
    for dst in NUMERIC
    for factor, offset in TRANSFORMS
    if _eligible(src, dst, factor, offset)
]


@pytest.mark.parametrize(("src_name", "dst_name", "factor", "offset"), CASES)
def test_the_kernel_converts_as_the_python_transfer_does(
    src_name: str, dst_name: str, factor: float, offset: float
) -> None:
    src = _values(np.dtype(src_name))
    python_dst = np.zeros(src.size, dtype=dst_name)
    native_dst = np.zeros(src.size, dtype=dst_name)
    connection = _connection(src, python_dst, factor, offset)
    transfer = make_transfer(connection, _Peer(src), _Peer(python_dst))  # type: ignore[arg-type]
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")  # numpy warns on overflow in a cast; the kernel does not
        transfer(0.0)
    assert _native(connection, src, native_dst) == k.OK
    assert native_dst.tobytes() == python_dst.tobytes(), (python_dst, native_dst)


def test_the_cases_cover_every_type_pair_the_kernel_accepts() -> None:
    assert len(CASES) == 11 * 11 * 3 - 8 * 11 * 3 + 8 * 9  # minus float/scaled into integers
    assert len({(s, d) for s, d, _, _ in CASES}) == 11 * 11 - 8 * 2


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize(("bad", "word"), [(np.nan, "NaN"), (np.inf, "inf"), (-np.inf, "-inf")])
def test_a_nonfinite_source_stops_the_kernel_as_it_stops_the_python_transfer(
    dtype: str, bad: float, word: str
) -> None:
    src = np.array([1.0, bad, 2.0], dtype=dtype)
    dst = np.zeros(3, dtype=np.float64)
    connection = _connection(src, dst, 1.0, 0.0)
    with pytest.raises(Exception, match=rf"^component `a`, port `y` at t=0 s: {word} on the "):
        make_transfer(connection, _Peer(src), _Peer(dst.copy()))(0.0)  # type: ignore[arg-type]
    assert _native(connection, src, dst) == k.NONFINITE
    assert not dst.any()  # nothing was copied
