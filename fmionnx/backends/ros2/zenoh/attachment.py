"""The attachment rmw_zenoh puts on every sample: sequence number, source time, publisher GID.

33 bytes, in zenoh's own serialisation of ``(int64, int64, [u8; 16])``: the sequence number
(int64 little endian, per publisher, from 1), the source timestamp in ns (int64 little endian;
rmw_zenoh writes the wall clock at publication), the GID's length as one LEB128 byte (``0x10``)
and the 16 GID bytes. Subscribers use the GID and sequence number to tell publishers apart and
to detect lost samples; ``fmionnx`` readers also hand the timestamp to the node.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

#: Size of the attachment.
SIZE = 33
_HEAD = struct.Struct("<qqB")


class AttachmentError(ValueError):
    """Bytes that are not an rmw_zenoh attachment."""


@dataclass(frozen=True, slots=True)
class Attachment:
    """One sample's attachment."""

    sequence: int
    timestamp_ns: int
    gid: bytes


def encode(sequence: int, timestamp_ns: int, gid: bytes) -> bytes:
    """The attachment bytes of one sample (``gid``: 16 bytes)."""
    return _HEAD.pack(sequence, timestamp_ns, len(gid)) + gid


def decode(data: bytes) -> Attachment:
    """Read an attachment; :class:`AttachmentError` when the bytes are not one."""
    if len(data) < _HEAD.size:
        msg = f"an rmw_zenoh attachment has {SIZE} bytes, this one {len(data)}"
        raise AttachmentError(msg)
    sequence, timestamp, length = _HEAD.unpack_from(data)
    gid = bytes(data[_HEAD.size : _HEAD.size + length])
    if length >= 0x80 or len(gid) != length:
        msg = f"the attachment's GID length {length} does not fit its {len(data)} bytes"
        raise AttachmentError(msg)
    return Attachment(sequence, timestamp, gid)
