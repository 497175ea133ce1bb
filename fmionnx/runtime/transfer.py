"""Connections as prepared copy operations between runner buffers.

Everything about a connection (element range, ``factor*x+offset``, dtype conversion, whether
a non-finite value can occur) is decided once; the master then calls one small closure per
connection and step. Scalar float connections, the common case, avoid numpy call overhead
entirely.

The non-finite guard lives here, at the one place every value crosses from a producer to a
consumer (the native kernel checks the same in C, :mod:`fmionnx.runtime.native`): a NaN or an
infinity leaving a producer on a connection is a fault naming the producer, its port and the
time (``--on-nonfinite fault``, the default: an FMU returning ``OK`` with a NaN output would
otherwise give wrong results silently), or, with ``--on-nonfinite warn``, a warning per
connection (:class:`NonFiniteWatch`) while the value is passed on. Checking costs one
``isfinite`` per scalar connection and step (docs/running.md, "Non-finite values").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from math import isfinite, isnan
from typing import Literal

import numpy as np

from fmionnx.compile.ir import Connection
from fmionnx.core.errors import RunError
from fmionnx.core.runner import Buffer, Runner
from fmionnx.core.types import Port, PortRef, flat_index

#: A prepared transfer; the argument is the simulated time (for error messages).
Transfer = Callable[[float], None]


def _element_range(port: Port, ref: PortRef, size: int, buffer: Buffer) -> Buffer:
    if ref.index is None:
        return buffer[:size] if buffer.size != size else buffer
    start = flat_index(port, ref.index)
    return buffer[start : start + 1]


#: What a non-finite value on a connection does (``--on-nonfinite``).
NonFinitePolicy = Literal["fault", "warn"]
NONFINITE_POLICIES: tuple[NonFinitePolicy, ...] = ("fault", "warn")


def nonfinite_word(values: Buffer | float) -> str:
    """``NaN``, ``inf`` or ``-inf``: the first non-finite value of ``values``."""
    flat = np.asarray(values, dtype=np.float64).reshape(-1)
    bad = flat[~np.isfinite(flat)]
    if bad.size == 0 or isnan(bad[0]):
        return "NaN"
    return "inf" if bad[0] > 0 else "-inf"


def nonfinite_error(connection: Connection, t: float, values: Buffer | float = np.nan) -> RunError:
    """The fault for a NaN or an infinity (in ``values``) leaving ``connection.src``."""
    src = connection.src
    return RunError(
        f"component `{src.component}`, port `{src.port_label}` at t={t:.6g} s: "
        f"{nonfinite_word(values)} on the connection `{connection}`",
        component=src.component,
        port=src.port_label,
        time=t,
    )


@dataclass
class NonFiniteSeen:
    """The first non-finite value on one connection, and how many steps carried one."""

    connection: Connection
    time: float
    word: str
    count: int = 1

    def message(self) -> str:
        """One line for the run's warnings."""
        src = self.connection.src
        more = f" ({self.count} transfers in all)" if self.count > 1 else ""
        return (
            f"component `{src.component}`, port `{src.port_label}` at t={self.time:.6g} s: "
            f"{self.word} on the connection `{self.connection}`, passed on "
            f"(--on-nonfinite warn){more}"
        )


class NonFiniteWatch:
    """``--on-nonfinite warn``: notes each connection's first non-finite value; the run goes on."""

    def __init__(self) -> None:
        self.seen: dict[int, NonFiniteSeen] = {}

    def saw(self, connection: Connection, t: float, values: Buffer | float) -> None:
        """A non-finite value crossed ``connection`` at ``t``."""
        found = self.seen.get(id(connection))
        if found is None:
            self.seen[id(connection)] = NonFiniteSeen(connection, t, nonfinite_word(values))
        else:
            found.count += 1

    def messages(self) -> list[str]:
        """The warnings, in the order the connections first carried a non-finite value."""
        return [seen.message() for seen in self.seen.values()]


def connection_views(
    connection: Connection, src_runner: Runner, dst_runner: Runner
) -> tuple[Buffer, Buffer]:
    """The producer and consumer elements a connection copies between (same size)."""
    src_buffer = src_runner.output_buffer(connection.src.port)
    dst_buffer = dst_runner.input_buffer(connection.dst.port)
    size = connection.size
    src = _element_range(connection.src_port, connection.src, size, src_buffer)
    dst = _element_range(connection.dst_port, connection.dst, size, dst_buffer)
    if src.size != dst.size:
        msg = f"{connection}: {src.size} elements cannot feed {dst.size}"
        raise RunError(msg, component=connection.dst.component, port=connection.dst.port)
    return src, dst


def make_transfer(
    connection: Connection,
    src_runner: Runner,
    dst_runner: Runner,
    before_read: Callable[[], None] | None = None,
    watch: NonFiniteWatch | None = None,
) -> Transfer:
    """A closure copying one connection's values from producer to consumer buffers.

    A non-finite value on a float connection raises the fault of :func:`nonfinite_error`;
    with ``watch`` (``--on-nonfinite warn``) it is noted there and passed on instead.
    """
    src, dst = connection_views(connection, src_runner, dst_runner)
    factor, offset = connection.factor, connection.offset
    identity = factor == 1.0 and offset == 0.0
    check_nan = np.issubdtype(src.dtype, np.floating)
    scalar = src.size == 1 and dst.dtype == np.float64 and src.dtype == np.float64
    if before_read is not None:
        produce = before_read

        def lazy(t: float) -> None:
            produce()
            np.copyto(dst, src.reshape(dst.shape), casting="unsafe")

        return lazy
    if watch is not None:
        return _watched(connection, src, dst, watch, check=bool(check_nan))
    if scalar and identity:

        def scalar_copy(t: float) -> None:
            value = src[0]
            if not isfinite(value):
                raise nonfinite_error(connection, t, value)
            dst[0] = value

        return scalar_copy
    if scalar:

        def scalar_linear(t: float) -> None:
            value = src[0]
            if not isfinite(value):
                raise nonfinite_error(connection, t, value)
            dst[0] = factor * value + offset

        return scalar_linear
    scratch = np.empty(src.shape, dtype=np.float64)

    def array_copy(t: float) -> None:
        if check_nan and not np.isfinite(src).all():
            raise nonfinite_error(connection, t, src)
        if identity:
            np.copyto(dst, src, casting="unsafe")
        else:
            np.multiply(src, factor, out=scratch)
            np.add(scratch, offset, out=scratch)
            np.copyto(dst, scratch, casting="unsafe")

    return array_copy


def _watched(
    connection: Connection, src: Buffer, dst: Buffer, watch: NonFiniteWatch, *, check: bool
) -> Transfer:
    """``--on-nonfinite warn``: the copy of :func:`make_transfer`, noting non-finite values
    in ``watch`` instead of raising (one closure for every shape: warn mode is a diagnosis
    setting, not the fast path)."""
    factor, offset = connection.factor, connection.offset
    identity = factor == 1.0 and offset == 0.0
    scratch = np.empty(src.shape, dtype=np.float64)

    def watched_copy(t: float) -> None:
        if check and not np.isfinite(src).all():
            watch.saw(connection, t, src)
        with np.errstate(invalid="ignore"):  # NaN into an integer port: noted above
            if identity:
                np.copyto(dst, src.reshape(dst.shape), casting="unsafe")
            else:
                np.multiply(src, factor, out=scratch)
                np.add(scratch, offset, out=scratch)
                np.copyto(dst, scratch.reshape(dst.shape), casting="unsafe")

    return watched_copy
