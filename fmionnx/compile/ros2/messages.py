"""ROS 2 message definitions from ``rosbags``' bundled typestores, and field paths into them.

Definitions are never hand-copied: :func:`typestore` returns the rosbags store of a ROS 2
distribution, whose ``fielddefs`` describe every standard message. A *field path* such as
``linear.x`` or ``pose.pose.orientation`` walks nested messages; :func:`resolve_field` says
what sits at the end (a scalar, a fixed array, a sequence or a nested message) so the compiler
can check it against a port's element type and shape.
"""

from __future__ import annotations

import enum
import functools
from dataclasses import dataclass
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_typestore

from fmionnx.compile.ros2.distro import DEFAULT_DISTRO, RosDistro
from fmionnx.core.types import DType

_STORES = {
    RosDistro.HUMBLE: Stores.ROS2_HUMBLE,
    RosDistro.IRON: Stores.ROS2_IRON,
    RosDistro.JAZZY: Stores.ROS2_JAZZY,
    RosDistro.KILTED: Stores.ROS2_KILTED,
}

#: ROS base types -> numpy dtypes (msg ``char`` is an unsigned byte, ``byte`` an octet).
BASE_NUMPY: dict[str, str] = {
    "bool": "bool",
    "byte": "uint8",
    "char": "uint8",
    "int8": "int8",
    "uint8": "uint8",
    "int16": "int16",
    "uint16": "uint16",
    "int32": "int32",
    "uint32": "uint32",
    "int64": "int64",
    "uint64": "uint64",
    "float32": "float32",
    "float64": "float64",
}

#: ROS base types -> the IR's element types.
BASE_DTYPE: dict[str, DType] = {
    "bool": DType.BOOL,
    "byte": DType.UINT8,
    "char": DType.UINT8,
    "int8": DType.INT8,
    "uint8": DType.UINT8,
    "int16": DType.INT16,
    "uint16": DType.UINT16,
    "int32": DType.INT32,
    "uint32": DType.UINT32,
    "int64": DType.INT64,
    "uint64": DType.UINT64,
    "float32": DType.FLOAT32,
    "float64": DType.FLOAT64,
    "string": DType.STRING,
}


@functools.cache
def typestore(distro: RosDistro = DEFAULT_DISTRO) -> Any:
    """The rosbags typestore of ``distro`` (cached; building one takes a few milliseconds)."""
    return get_typestore(_STORES[distro])


@functools.cache
def fielddefs(distro: RosDistro = DEFAULT_DISTRO) -> Any:
    """Every message's constants and fields in ``distro`` (the typestore's ``fielddefs``),
    kept in the cache folder so that a compile need not import the typestore
    (:mod:`.typecache`)."""
    from fmionnx.compile.ros2.typecache import kept_fielddefs

    return kept_fielddefs(_STORES[distro].value, lambda: typestore(distro).fielddefs)


def message_types(distro: RosDistro = DEFAULT_DISTRO) -> tuple[str, ...]:
    """Every message type the store defines, e.g. ``geometry_msgs/msg/Twist``."""
    return tuple(sorted(fielddefs(distro)))


def normalize_type(name: str) -> str:
    """Accept ``geometry_msgs/Twist`` (ROS 1 style) as ``geometry_msgs/msg/Twist``."""
    parts = name.strip().split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name.strip()


class FieldKind(enum.StrEnum):
    """What a field path ends on."""

    SCALAR = "scalar"
    ARRAY = "array"
    SEQUENCE = "sequence"
    MESSAGE = "message"


@dataclass(frozen=True, slots=True)
class FieldInfo:
    """The end of a field path: its kind, element base type and (for arrays) length.

    ``base`` is a ROS base type (``float64``, ``string`` ...) for scalars, arrays and
    sequences of base types, or the message type name for a nested message / a sequence or
    array of messages. ``length`` is the fixed length of an array, the bound of a bounded
    sequence, 0 otherwise. ``members`` lists, for a nested message, its members' names.
    """

    kind: FieldKind
    base: str
    length: int = 0
    element_is_message: bool = False
    members: tuple[str, ...] = ()

    @property
    def dtype(self) -> DType | None:
        """The element type as IR dtype, or None for messages."""
        return None if self.element_is_message else BASE_DTYPE.get(self.base)


class FieldError(LookupError):
    """A field path does not exist in a message; ``valid`` lists the members at the failure."""

    def __init__(self, message: str, valid: tuple[str, ...]) -> None:
        self.valid = valid
        super().__init__(message)


def field_info(definition: tuple[Any, Any]) -> FieldInfo:
    """Describe one rosbags field definition (``(Nodetype, argument)``)."""
    kind, arg = definition
    if kind == Nodetype.BASE:
        return FieldInfo(FieldKind.SCALAR, arg[0], arg[1])
    if kind == Nodetype.NAME:
        return FieldInfo(FieldKind.MESSAGE, arg, element_is_message=True)
    inner_kind, inner_arg = arg[0]
    is_message = inner_kind == Nodetype.NAME
    base = inner_arg if is_message else inner_arg[0]
    field_kind = FieldKind.ARRAY if kind == Nodetype.ARRAY else FieldKind.SEQUENCE
    return FieldInfo(field_kind, base, arg[1], element_is_message=is_message)


def members(msgtype: str, distro: RosDistro = DEFAULT_DISTRO) -> tuple[str, ...]:
    """Member names of a message type, in declaration order."""
    return tuple(name for name, _ in fielddefs(distro)[msgtype][1])


def resolve_field(msgtype: str, path: str, distro: RosDistro = DEFAULT_DISTRO) -> FieldInfo:
    """What ``path`` (``linear.x``; ``""`` = the whole message) refers to in ``msgtype``.

    Raises :class:`FieldError` naming the first part that does not exist, and
    :class:`KeyError` when ``msgtype`` is unknown.
    """
    definitions_of = fielddefs(distro)
    current = FieldInfo(
        FieldKind.MESSAGE, msgtype, element_is_message=True, members=members(msgtype, distro)
    )
    walked: list[str] = []
    for part in [p for p in path.split(".") if p] if path else []:
        if current.kind is not FieldKind.MESSAGE:
            where = ".".join(walked)
            msg = (
                f"`{where}` is a {current.kind.value} of {current.base}, it has no member `{part}`"
            )
            raise FieldError(msg, ())
        definitions = dict(definitions_of[current.base][1])
        if part not in definitions:
            owner = ".".join(walked) or current.base
            msg = f"`{owner}` has no member `{part}`"
            raise FieldError(msg, tuple(definitions))
        walked.append(part)
        current = field_info(definitions[part])
        if current.kind is FieldKind.MESSAGE:
            current = FieldInfo(
                FieldKind.MESSAGE,
                current.base,
                element_is_message=True,
                members=members(current.base, distro),
            )
    return current


def numeric_leaves(msgtype: str, distro: RosDistro = DEFAULT_DISTRO) -> tuple[str, ...] | None:
    """Member names of a message made only of numeric scalars (``Vector3`` -> x, y, z).

    None when a member is not a numeric scalar; used to map an array port onto a struct.
    """
    names: list[str] = []
    for name, definition in fielddefs(distro)[msgtype][1]:
        info = field_info(definition)
        if info.kind is not FieldKind.SCALAR or info.base == "string":
            return None
        names.append(name)
    return tuple(names)


def default_message(msgtype: str, distro: RosDistro = DEFAULT_DISTRO) -> Any:
    """A message of ``msgtype`` with every member zero / empty (like a ROS 2 constructor)."""
    store = typestore(distro)
    values: dict[str, Any] = {}
    for name, definition in store.fielddefs[msgtype][1]:
        values[name] = _default_value(field_info(definition), distro)
    return store.types[msgtype](**values)


def _default_value(info: FieldInfo, distro: RosDistro) -> Any:
    import numpy as np  # only here: a compile checks topics without numpy

    if info.kind is FieldKind.MESSAGE:
        return default_message(info.base, distro)
    if info.kind is FieldKind.SCALAR:
        if info.base == "string":
            return ""
        if info.base == "bool":
            return False
        return 0.0 if info.base.startswith("float") else 0
    if info.kind is FieldKind.ARRAY:
        if info.element_is_message:
            return [default_message(info.base, distro) for _ in range(info.length)]
        if info.base == "string":
            return [""] * info.length
        return np.zeros(info.length, dtype=BASE_NUMPY[info.base])
    if info.element_is_message or info.base == "string":
        return []
    return np.zeros(0, dtype=BASE_NUMPY[info.base])


def serialize(message: Any, msgtype: str, distro: RosDistro = DEFAULT_DISTRO) -> bytes:
    """XCDR1 little-endian bytes with the 4-byte encapsulation header, as on the ROS 2 wire."""
    return bytes(typestore(distro).serialize_cdr(message, msgtype))


def deserialize(data: bytes | memoryview, msgtype: str, distro: RosDistro = DEFAULT_DISTRO) -> Any:
    """Decode CDR bytes (with header) into a rosbags message; primitive arrays stay numpy views."""
    return typestore(distro).deserialize_cdr(data, msgtype)


# The distributions live in .distro (no rosbags there); they are still found here.
__all__ = [
    "BASE_DTYPE",
    "BASE_NUMPY",
    "DEFAULT_DISTRO",
    "FieldError",
    "FieldInfo",
    "FieldKind",
    "RosDistro",
    "default_message",
    "deserialize",
    "field_info",
    "members",
    "message_types",
    "normalize_type",
    "numeric_leaves",
    "resolve_field",
    "serialize",
    "typestore",
]
