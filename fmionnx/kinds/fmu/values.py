"""Value-reference arrays and value buffers of an FMU, prepared once per run.

fmpy's convenience methods (``getReal([vr])``) build ctypes arrays on every call, which costs
more than the FMU's own work for small models. Here every port's value references and values
live in ctypes arrays created at setup, one group per FMI type, with numpy views over the same
memory; a step then costs exactly one raw FMI call per type and direction.
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fmionnx.core.runner import Buffer
from fmionnx.core.types import DType, Port, Scalar

#: FMI 2 type name and C element type per dtype (FMI 2 Boolean is a C int).
FMI2_TYPES: dict[DType, tuple[str, Any]] = {
    DType.FLOAT64: ("Real", ctypes.c_double),
    DType.INT32: ("Integer", ctypes.c_int),
    DType.BOOL: ("Boolean", ctypes.c_int),
}

#: FMI 3 type name and C element type per dtype.
FMI3_TYPES: dict[DType, tuple[str, Any]] = {
    DType.FLOAT64: ("Float64", ctypes.c_double),
    DType.FLOAT32: ("Float32", ctypes.c_float),
    DType.INT8: ("Int8", ctypes.c_int8),
    DType.UINT8: ("UInt8", ctypes.c_uint8),
    DType.INT16: ("Int16", ctypes.c_int16),
    DType.UINT16: ("UInt16", ctypes.c_uint16),
    DType.INT32: ("Int32", ctypes.c_int32),
    DType.UINT32: ("UInt32", ctypes.c_uint32),
    DType.INT64: ("Int64", ctypes.c_int64),
    DType.UINT64: ("UInt64", ctypes.c_uint64),
    DType.BOOL: ("Boolean", ctypes.c_bool),
}

RawCall = tuple[Callable[..., int], tuple[object, ...], str]


@dataclass
class ValueGroup:
    """All ports of one FMI type and direction: one vr array, one value array, one call.

    ``views`` maps each port to its flat slice of ``array`` (numpy over the ctypes memory).
    ``call`` is ``(raw function, prepared arguments, function name)``.
    """

    type_name: str
    array: Buffer
    views: dict[str, Buffer]
    call: RawCall


def port_element_count(port: Port) -> int:
    """Number of values of a port (FMI 3 arrays have one vr for many values)."""
    size = port.size
    return 1 if size is None or not port.shape else size


def build_groups(
    dll: Any,
    instance: ctypes.c_void_p,
    ports: Sequence[Port],
    *,
    fmi3: bool,
    setter: bool,
) -> list[ValueGroup]:
    """Group ``ports`` by FMI type and prepare the raw get/set call of each group."""
    table = FMI3_TYPES if fmi3 else FMI2_TYPES
    by_type: dict[str, list[Port]] = {}
    for port in ports:
        if port.dtype not in table:
            continue  # strings and binaries: set at setup only, never per step
        by_type.setdefault(table[port.dtype][0], []).append(port)
    groups = []
    for type_name, members in by_type.items():
        ctype = next(c for n, c in table.values() if n == type_name)
        vrs = [vr for port in members for vr in port.vrs]
        counts = [port_element_count(port) for port in members]
        vr_array = (ctypes.c_uint * len(vrs))(*vrs)
        values = (ctype * sum(counts))()
        array: Buffer = np.ctypeslib.as_array(values)
        views: dict[str, Buffer] = {}
        offset = 0
        for port, count in zip(members, counts, strict=True):
            views[port.name] = array[offset : offset + count]
            offset += count
        prefix = "fmi3" if fmi3 else "fmi2"
        name = f"{prefix}{'Set' if setter else 'Get'}{type_name}"
        function = getattr(dll, name)
        args: tuple[object, ...] = (instance, vr_array, len(vrs), values)
        if fmi3:
            args = (*args, sum(counts))
        # keep the ctypes objects alive as long as the group
        groups.append(ValueGroup(type_name, array, views, (function, args, name)))
    return groups


def set_scalars(
    dll: Any, instance: ctypes.c_void_p, port: Port, values: Sequence[Scalar], *, fmi3: bool
) -> tuple[str, int]:
    """Set one port's values once (parameters, start values, strings); returns (name, status)."""
    table = FMI3_TYPES if fmi3 else FMI2_TYPES
    prefix = "fmi3" if fmi3 else "fmi2"
    vr_array = (ctypes.c_uint * len(port.vrs))(*port.vrs)
    if port.dtype is DType.STRING:
        name = f"{prefix}SetString"
        strings = (ctypes.c_char_p * len(values))(*(str(v).encode() for v in values))
        args: tuple[object, ...] = (instance, vr_array, len(port.vrs), strings)
    else:
        type_name, ctype = table[port.dtype]
        name = f"{prefix}Set{type_name}"
        array = (ctype * len(values))(*values)
        args = (instance, vr_array, len(port.vrs), array)
    if fmi3:
        args = (*args, len(values))
    status = getattr(dll, name)(*args)
    return name, int(status)
