"""Port values <-> ROS 2 messages for one topic.

A topic carries one message type; one or more ports of the publishing component fill fields
of it (``/cmd_vel``: ``v`` -> ``linear.x``, ``w`` -> ``angular.z``). A port maps onto one
field path (a scalar, a fixed array, a sequence, or a message made of numeric scalars), or onto
one scalar field path per element (a quaternion in MuJoCo's ``w, x, y, z`` order onto
``orientation.w/x/y/z``). An image port maps onto a whole ``sensor_msgs/msg/Image``.
Primitive arrays go in and out as numpy arrays so that large messages cost one copy.
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
            return ("elements", None)
        info = resolve_field(self.msgtype, field.paths[0], self.distro)
        if info.kind is FieldKind.SCALAR:
            return ("scalar", info.base)
        if info.kind is FieldKind.MESSAGE:
            return ("struct", numeric_leaves(info.base, self.distro))
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
            _set(message, field.paths[0], _scalar(flat[0], extra))
        elif kind == "elements":
            for path, element in zip(field.paths, flat, strict=True):
                _set(message, path, float(element))
        elif kind == "struct":
            target = _get(message, field.paths[0])
            for name, element in zip(extra, flat, strict=True):
                setattr(target, name, float(element))
        else:
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
        if kind == "elements":
            return np.array([_get(message, p) for p in field.paths], dtype=np.float64)
        if kind == "struct":
            target = _get(message, field.paths[0])
            return np.array([getattr(target, n) for n in extra], dtype=np.float64)
        array = np.asarray(_get(message, field.paths[0])).reshape(-1)
        if array.size != field.size:
            msg = (
                f"{self.msgtype}.{field.paths[0]} holds {array.size} elements, port "
                f"`{field.port}` takes {field.size}"
            )
            raise RunError(msg, port=field.port)
        return array


def _scalar(value: Any, base: str) -> Any:
    if base == "string":
        return str(value)
    if base == "bool":
        return bool(value)
    if base.startswith("float"):
        return float(value)
    return int(value)


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
