"""Connections as prepared copy operations between runner buffers.

Everything about a connection (element range, ``factor*x+offset``, dtype conversion, whether
NaN can occur) is decided once; the master then calls one small closure per connection and
step. Scalar float connections, the common case, avoid numpy call overhead entirely.
"""

from __future__ import annotations

from collections.abc import Callable
from math import isnan

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


def nan_error(connection: Connection, t: float) -> RunError:
    """The fault for a NaN leaving ``connection.src``."""
    src = connection.src
    return RunError(
        f"component `{src.component}`, port `{src.port_label}` at t={t:.6g} s: NaN on the "
        f"connection `{connection}`",
        component=src.component,
        port=src.port_label,
        time=t,
    )


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
) -> Transfer:
    """A closure copying one connection's values from producer to consumer buffers."""
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
    if scalar and identity:

        def scalar_copy(t: float) -> None:
            value = src[0]
            if isnan(value):
                raise nan_error(connection, t)
            dst[0] = value

        return scalar_copy
    if scalar:

        def scalar_linear(t: float) -> None:
            value = src[0]
            if isnan(value):
                raise nan_error(connection, t)
            dst[0] = factor * value + offset

        return scalar_linear
    scratch = np.empty(src.shape, dtype=np.float64)

    def array_copy(t: float) -> None:
        if check_nan and np.isnan(src).any():
            raise nan_error(connection, t)
        if identity:
            np.copyto(dst, src, casting="unsafe")
        else:
            np.multiply(src, factor, out=scratch)
            np.add(scratch, offset, out=scratch)
            np.copyto(dst, scratch, casting="unsafe")

    return array_copy
