"""Port values <-> ROS 2 messages for one topic.

A topic carries one message type; one or more ports of the publishing component fill fields
of it (``/cmd_vel``: ``v`` -> ``linear.x``, ``w`` -> ``angular.z``). A port maps onto one
field path (a scalar, a fixed array, a sequence, or a message made of numeric scalars), or onto
one scalar field path per element (a quaternion in MuJoCo's ``w, x, y, z`` order onto
``orientation.w/x/y/z``). An image port maps onto a whole ``sensor_msgs/msg/Image``.
Primitive arrays go in and out as numpy arrays so that large messages cost one copy.

Integer fields carry integer values exactly (``int64`` and ``uint64`` included): a value is
converted to the field's own type, never through a float, and decoded in the field's type. A
value that the field cannot hold (``2**40`` into an ``int32``, a NaN into any integer) is a
fault naming the port, the field and the value, for a scalar, an element, a nested message
and an array alike, rather than a wrapped number on the wire (the compiler warns of such a
mapping with W060; this is the run-time side of it).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ros2.fields import WHOLE, PortField, image_geometry
from fmionnx.compile.ros2.messages import (
    BASE_NUMPY,
    FieldKind,
    RosDistro,
    default_message,
    deserialize,
    members,
    numeric_leaves,
    resolve_field,
    serialize,
    typestore,
)
from fmionnx.core.errors import RunError

Array = npt.NDArray[Any]


def _get(message: Any, path: str) -> Any:
    value = message
    for part in path.split("."):
        value = getattr(value, part)
    return value


def _set(message: Any, path: str, value: Any) -> None:
    parent_path, _, name = path.rpartition(".")
    parent = _get(message, parent_path) if parent_path else message
    setattr(parent, name, value)


def _seconds_to_time(store: Any, seconds: float) -> Any:
    sec = int(np.floor(seconds))
    nanosec = round((seconds - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def time_to_seconds(stamp: Any) -> float:
    """``builtin_interfaces/msg/Time`` -> seconds."""
    return float(stamp.sec) + float(stamp.nanosec) * 1e-9


class TopicCodec:
    """Encodes the ports of one publisher into messages and decodes them back."""

    def __init__(
        self,
        msgtype: str,
        fields: tuple[PortField, ...],
        distro: RosDistro,
        *,
        frame_id: str = "",
    ) -> None:
        self.msgtype = msgtype
        self.fields = fields
        self.distro = distro
        self.frame_id = frame_id
        self._store = typestore(distro)
        self._has_header = "header" in members(msgtype, distro)
        self._plans = {f.port: self._plan(f) for f in fields}

    def _plan(self, field: PortField) -> tuple[str, Any]:
        if field.paths == (WHOLE,):
            return ("image", None)
        if len(field.paths) > 1:
            leaves = tuple(
                (p, resolve_field(self.msgtype, p, self.distro).base) for p in field.paths
            )
            return ("elements", leaves)
        info = resolve_field(self.msgtype, field.paths[0], self.distro)
        if info.kind is FieldKind.SCALAR:
            return ("scalar", info.base)
        if info.kind is FieldKind.MESSAGE:
            names = numeric_leaves(info.base, self.distro) or ()
            path = field.paths[0]
            leaves = tuple(
                (f"{path}.{n}", resolve_field(self.msgtype, f"{path}.{n}", self.distro).base)
                for n in names
            )
            return ("struct", leaves)
        return ("array", BASE_NUMPY.get(info.base, "float64"))

    # --- encoding
    def encode(self, values: Mapping[str, Array], stamp: float = 0.0) -> bytes:
        """CDR bytes of a message holding ``values`` (by port name), stamped ``stamp``."""
        message = default_message(self.msgtype, self.distro)
        if self._has_header:
            message.header.stamp = _seconds_to_time(self._store, stamp)
            message.header.frame_id = self.frame_id
        for field in self.fields:
            self._put(message, field, np.asarray(values[field.port]))
        return serialize(message, self.msgtype, self.distro)

    def _put(self, message: Any, field: PortField, value: Array) -> None:
        kind, extra = self._plans[field.port]
        flat = value.reshape(-1)
        if kind == "image":
            # Decoded values are flat; a node may forward them as they are.
            _fill_image(message, value.reshape(field.shape) if value.ndim == 1 else value)
        elif kind == "scalar":
            _set(message, field.paths[0], self._scalar(field.port, field.paths[0], extra, flat[0]))
        elif kind in ("elements", "struct"):
            for (path, base), element in zip(extra, flat, strict=True):
                _set(message, path, self._scalar(field.port, path, base, element))
        else:
            self._check_range(field.port, field.paths[0], flat, np.dtype(extra))
            _set(message, field.paths[0], np.ascontiguousarray(flat, dtype=extra))
            if field.paths[0] == "data" and hasattr(message, "layout"):
                _fill_layout(self._store, message, field.shape)

    # --- decoding
    def decode(self, data: bytes) -> tuple[dict[str, Array], float | None]:
        """Port values (flat arrays of the port's size) and the header stamp, if any."""
        message = deserialize(data, self.msgtype, self.distro)
        stamp = time_to_seconds(message.header.stamp) if self._has_header else None
        return {f.port: self._take(message, f) for f in self.fields}, stamp

    def _take(self, message: Any, field: PortField) -> Array:
        kind, extra = self._plans[field.port]
        if kind == "image":
            return _read_image(message, field)
        if kind == "scalar":
            # The field's own type: an int64 in a float64 would lose bits above 2**53.
            dtype = object if extra == "string" else BASE_NUMPY.get(extra, "float64")
            return np.array([_get(message, field.paths[0])], dtype=dtype)
        if kind in ("elements", "struct"):
            # In the fields' own type, as a scalar: int64 members keep their bits above 2**53.
            common = _common_dtype([base for _, base in extra], field.dtype)
            return np.array([_get(message, path) for path, _ in extra], dtype=common)
        array = np.asarray(_get(message, field.paths[0])).reshape(-1)
        if array.size != field.size:
            msg = (
                f"{self.msgtype}.{field.paths[0]} holds {array.size} elements, port "
                f"`{field.port}` takes {field.size}"
            )
            raise RunError(msg, port=field.port)
        return array

    # --- values into fields
    def _scalar(self, port: str, path: str, base: str, value: Any) -> Any:
        """``value`` as the Python value of a ``base`` field: an integer field gets an
        integer made without a float (exact up to 2**64), a fault when it does not fit."""
        if base == "string":
            return str(value)
        if base == "bool":
            return bool(value)
        if base.startswith("float"):
            return float(value)
        info = np.iinfo(BASE_NUMPY.get(base, "int64"))
        number = _integer(value)
        if number is None or not info.min <= number <= info.max:
            raise self._out_of_range(port, path, base, value, info)
        return number

    def _check_range(self, port: str, path: str, values: Array, target: np.dtype[Any]) -> None:
        """A fault when an element of ``values`` does not fit an integer array field of
        ``target`` (numpy would wrap it); checked only where the port's type can exceed it."""
        if target.kind not in "iu" or values.size == 0 or np.can_cast(values.dtype, target):
            return
        info = np.iinfo(target)
        if values.dtype.kind == "f":
            whole = np.trunc(values)
            # ``min`` and ``max + 1`` are 0 or powers of two: exact in any float.
            bad = ~np.isfinite(whole) | (whole < float(info.min)) | (whole >= float(info.max) + 1)
        elif values.dtype.kind in "iu":
            source = np.iinfo(values.dtype)
            bad = np.zeros(values.shape, dtype=bool)
            if source.min < info.min:
                bad |= values < values.dtype.type(info.min)
            if source.max > info.max:
                bad |= values > values.dtype.type(info.max)
        else:
            return
        if bad.any():
            base = target.name
            raise self._out_of_range(port, path, base, values[np.argmax(bad)], info)

    def _out_of_range(
        self, port: str, path: str, base: str, value: Any, info: np.iinfo[Any]
    ) -> RunError:
        msg = (
            f"port `{port}` sends {_shown(value)}, which field `{path}` of `{self.msgtype}` "
            f"({base}, {info.min}..{info.max}) cannot hold"
        )
        return RunError(msg, port=port)


def _integer(value: Any) -> int | None:
    """``value`` as a Python int (a float's fraction cut off, as numpy casts), or None for a
    NaN or an infinity. Integers never pass through a float: int64/uint64 stay exact."""
    if isinstance(value, float | np.floating):
        return int(value) if np.isfinite(value) else None
    return int(value)


def _shown(value: Any) -> str:
    """A value as a user reads it: ``1099511627776``, ``nan``, ``3.5``."""
    return str(value.item() if isinstance(value, np.generic) else value)


def _common_dtype(bases: list[str], port_dtype: str) -> np.dtype[Any]:
    """One dtype holding every field of ``bases`` exactly: the fields' own when they agree,
    their promotion otherwise; the port's type where numpy would promote integers to a
    float (``int64`` beside ``uint64``)."""
    dtypes = [np.dtype(BASE_NUMPY.get(base, "float64")) for base in bases]
    common = np.result_type(*dtypes) if dtypes else np.dtype(np.float64)
    if common.kind == "f" and all(d.kind in "iub" for d in dtypes):
        return np.dtype(port_dtype)
    return common


def _fill_layout(store: Any, message: Any, shape: tuple[int, ...]) -> None:
    dims = shape or (1,)
    dimension = store.types["std_msgs/msg/MultiArrayDimension"]
    strides = [int(np.prod(dims[i:])) for i in range(len(dims))]
    message.layout.dim = [
        dimension(label=f"dim{i}", size=int(d), stride=s)
        for i, (d, s) in enumerate(zip(dims, strides, strict=True))
    ]
    message.layout.data_offset = 0


_ENCODINGS = {1: "mono8", 3: "rgb8", 4: "rgba8"}


def _fill_image(message: Any, value: Array) -> None:
    geometry = image_geometry(value.shape)
    if geometry is None:
        msg = f"an image of shape {value.shape} is not [H,W,C] or [1,H,W,C]"
        raise RunError(msg)
    height, width, channels = geometry
    message.height, message.width = height, width
    message.encoding = _ENCODINGS[channels]
    message.is_bigendian = 0
    message.step = width * channels
    message.data = np.ascontiguousarray(value, dtype=np.uint8).reshape(-1)


def _read_image(message: Any, field: PortField) -> Array:
    geometry = image_geometry(field.shape)
    if geometry is None:  # pragma: no cover - the mapping only builds image codecs for images
        msg = f"port `{field.port}` is not an image"
        raise RunError(msg, port=field.port)
    height, width, channels = geometry
    encoding = message.encoding
    data = np.asarray(message.data, dtype=np.uint8)
    if (message.height, message.width) != (height, width):
        msg = (
            f"image of {message.width}x{message.height} received, port `{field.port}` "
            f"takes {width}x{height}"
        )
        raise RunError(msg, port=field.port)
    rows = data.reshape(height, message.step)[:, : width * _channels_of(encoding, field.port)]
    pixels = rows.reshape(height, width, -1)
    if encoding.startswith("bgr"):
        pixels = pixels[:, :, [2, 1, 0, *range(3, pixels.shape[2])]]
    if pixels.shape[2] != channels:
        msg = f"image encoding `{encoding}` does not give the {channels} channels of `{field.port}`"
        raise RunError(msg, port=field.port)
    return pixels.reshape(-1)


def _channels_of(encoding: str, port: str) -> int:
    known = {"mono8": 1, "8UC1": 1, "rgb8": 3, "bgr8": 3, "8UC3": 3, "rgba8": 4, "bgra8": 4}
    if encoding not in known:
        msg = f"image encoding `{encoding}` is not supported for port `{port}` (use rgb8)"
        raise RunError(msg, port=port)
    return known[encoding]
