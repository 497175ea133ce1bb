"""Value-reference arrays and value buffers of an FMU, prepared once per run.

fmpy's convenience methods (``getReal([vr])``) build ctypes arrays on every call, which costs
more than the FMU's own work for small models. Here every port's value references and values
live in ctypes arrays created at setup, one group per FMI type, with numpy views over the same
memory; a step then costs exactly one raw FMI call per type and direction.
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fmionnx.core.cosim import RawCall
from fmionnx.core.runner import Buffer
from fmionnx.core.types import DType, Port, Scalar


@dataclass(frozen=True)
class ValueFunctions:
    """How one FMI version names and calls its get/set functions (``fmi2.VALUES`` ...).

    ``types`` maps a dtype to the FMI type name in the function names and the C element type;
    ``counts_values``: the functions take the number of values after the value array (FMI 3,
    whose arrays have one value reference for many values).
    """

    prefix: str
    types: Mapping[DType, tuple[str, Any]]
    counts_values: bool

    def name(self, verb: str, type_name: str) -> str:
        """``fmi2SetReal``, ``fmi3GetFloat64`` ..."""
        return f"{self.prefix}{verb}{type_name}"


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
    functions: ValueFunctions,
    *,
    setter: bool,
) -> list[ValueGroup]:
    """Group ``ports`` by FMI type and prepare the raw get/set call of each group."""
    table = functions.types
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
        name = functions.name("Set" if setter else "Get", type_name)
        function = getattr(dll, name)
        args: tuple[object, ...] = (instance, vr_array, len(vrs), values)
        if functions.counts_values:
            args = (*args, sum(counts))
        # keep the ctypes objects alive as long as the group
        groups.append(ValueGroup(type_name, array, views, (function, args, name)))
    return groups


def set_scalars(
    dll: Any,
    instance: ctypes.c_void_p,
    port: Port,
    values: Sequence[Scalar],
    functions: ValueFunctions,
) -> tuple[str, int]:
    """Set one port's values once (parameters, start values, strings); returns (name, status).

    A binary value is written as hexadecimal text (``0c0d``), as FMI 3 writes binary start
    values; the compiler has checked it (:func:`binary_bytes` raises ValueError otherwise).
    """
    vr_array = (ctypes.c_uint * len(port.vrs))(*port.vrs)
    if port.dtype is DType.STRING:
        name = functions.name("Set", "String")
        strings = (ctypes.c_char_p * len(values))(*(str(v).encode() for v in values))
        args: tuple[object, ...] = (instance, vr_array, len(port.vrs), strings)
    elif port.dtype is DType.BINARY:
        name = functions.name("Set", "Binary")
        blobs = [binary_bytes(v) for v in values]
        sizes = (ctypes.c_size_t * len(blobs))(*(len(b) for b in blobs))
        pointer = ctypes.POINTER(ctypes.c_uint8)
        data = [ctypes.create_string_buffer(b, max(1, len(b))) for b in blobs]
        pointers = (pointer * len(blobs))(*(ctypes.cast(d, pointer) for d in data))
        # fmi3SetBinary(instance, vrs, nvrs, valueSizes, values, nValues)
        args = (instance, vr_array, len(port.vrs), sizes, pointers)
    else:
        type_name, ctype = functions.types[port.dtype]
        name = functions.name("Set", type_name)
        array = (ctype * len(values))(*values)
        args = (instance, vr_array, len(port.vrs), array)
    if functions.counts_values:
        args = (*args, len(values))
    status = getattr(dll, name)(*args)
    return name, int(status)


def binary_bytes(value: Scalar) -> bytes:
    """The bytes of a binary value written as hexadecimal text (``0c0d``, ``0C 0D``); a
    ValueError names what is wrong."""
    try:
        return bytes.fromhex(str(value))
    except ValueError:
        msg = f"`{value}` is not hexadecimal text of whole bytes (write a binary value as `0c0d`)"
        raise ValueError(msg) from None
