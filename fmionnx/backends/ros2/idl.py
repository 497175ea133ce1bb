"""cyclonedds IDL types generated from the rosbags definitions, in ROS 2's DDS naming.

The DDS topic needs a type: its name (``geometry_msgs::msg::dds_::Twist_``) is what
``rmw_cyclonedds_cpp`` matches on, and the ``cyclonedds`` package also sends XTypes type
information, so members are spelled exactly as ROS 2's generated IDL spells them (msg
``uint8``/``char`` -> ``uint8``, ``byte`` -> ``octet``, ``string<N>`` bounded, final structs).
Samples never go through these classes on the hot path (see :mod:`.transport`): they only
declare the topic. They also serve as an independent CDR implementation in tests.
"""

from __future__ import annotations

import functools
from typing import Any

from cyclonedds.idl import IdlStruct, make_idl_struct
from cyclonedds.idl import types as idl_types
from cyclonedds.idl.annotations import final

from fmionnx.compile.ros2.messages import (
    DEFAULT_DISTRO,
    FieldInfo,
    FieldKind,
    RosDistro,
    field_info,
    typestore,
)

# The generic IDL containers are subscripted at run time; typed as Any for mypy.
_ARRAY: Any = idl_types.array
_SEQUENCE: Any = idl_types.sequence
_BOUNDED_STR: Any = idl_types.bounded_str

_BASE: dict[str, Any] = {
    "bool": bool,
    "byte": idl_types.byte,
    "char": idl_types.uint8,
    "int8": idl_types.int8,
    "uint8": idl_types.uint8,
    "int16": idl_types.int16,
    "uint16": idl_types.uint16,
    "int32": idl_types.int32,
    "uint32": idl_types.uint32,
    "int64": idl_types.int64,
    "uint64": idl_types.uint64,
    "float32": idl_types.float32,
    "float64": idl_types.float64,
}


def dds_type_name(msgtype: str) -> str:
    """``geometry_msgs/msg/Twist`` -> ``geometry_msgs::msg::dds_::Twist_``."""
    package, interface, name = msgtype.split("/")
    return f"{package}::{interface}::dds_::{name}_"


def ros_type_name(dds_name: str) -> str | None:
    """Inverse of :func:`dds_type_name`; None for a name that does not follow ROS 2's rule."""
    parts = dds_name.split("::")
    if len(parts) != 4 or parts[2] != "dds_" or not parts[3].endswith("_"):
        return None
    return f"{parts[0]}/{parts[1]}/{parts[3][:-1]}"


@functools.cache
def idl_type(msgtype: str, distro: RosDistro = DEFAULT_DISTRO) -> type[IdlStruct]:
    """The cyclonedds struct for ``msgtype`` (cached, so nested types are shared)."""
    fields = {
        name: _member(field_info(definition), distro)
        for name, definition in typestore(distro).fielddefs[msgtype][1]
    }
    cls = make_idl_struct(msgtype.rsplit("/", 1)[1] + "_", dds_type_name(msgtype), fields)
    final(cls)
    return cls


def _element(info: FieldInfo, distro: RosDistro) -> Any:
    if info.element_is_message:
        return idl_type(info.base, distro)
    if info.base == "string":
        return _BOUNDED_STR[info.length] if info.length else str
    return _BASE[info.base]


def _member(info: FieldInfo, distro: RosDistro) -> Any:
    if info.kind is FieldKind.MESSAGE:
        return idl_type(info.base, distro)
    if info.kind is FieldKind.SCALAR:
        return _element(info, distro)
    element = _element(FieldInfo(FieldKind.SCALAR, info.base, 0, info.element_is_message), distro)
    if info.kind is FieldKind.ARRAY:
        return _ARRAY[element, info.length]
    if info.length:
        return _SEQUENCE[element, info.length]
    return _SEQUENCE[element]
