"""Integer fields on a topic: exact values, and a fault for a value the field cannot hold.

A port mapped element by element (or onto a nested message) went through ``float()``: an
``int64`` value above 2**53 was rounded (and an integer field refused the float with a bare
``struct.error``). A value out of the field's range raised ``struct.error`` for a scalar field
and wrapped silently in an array. Now every shape carries integers exactly and reports a
value that does not fit as a fault naming the port, the field and the value. Codec level: the
bytes are read back with the message library itself, no DDS session.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from fmionnx.backends.ros2.codec import TopicCodec
from fmionnx.compile.ros2.fields import PortField
from fmionnx.compile.ros2.messages import RosDistro, deserialize
from fmionnx.core.errors import RunError

DISTRO = RosDistro.JAZZY
RANGE = "rcl_interfaces/msg/IntegerRange"  # int64 from_value, int64 to_value, uint64 step
ELEMENTS = ("from_value", "to_value", "step")


def _codec(msgtype: str, paths: tuple[str, ...], shape: tuple[int, ...], dtype: str) -> TopicCodec:
    return TopicCodec(msgtype, (PortField("y", paths, shape, dtype),), DISTRO)


def _roundtrip(codec: TopicCodec, value: Any, dtype: str) -> tuple[Any, np.ndarray[Any, Any]]:
    """The message as the wire holds it (read by the message library), and the decoded port."""
    data = codec.encode({"y": np.array(value, dtype=dtype)})
    decoded, _ = codec.decode(data)
    return deserialize(data, codec.msgtype, DISTRO), decoded["y"]


def test_int64_elements_keep_their_bits_above_2_53() -> None:
    values = [2**53 + 1, -(2**63), 2**63 - 1]
    codec = _codec(RANGE, ELEMENTS, (3,), "int64")
    message, decoded = _roundtrip(codec, values, "int64")
    assert [message.from_value, message.to_value, message.step] == values
    assert decoded.dtype == np.int64
    assert decoded.tolist() == values


def test_uint64_elements_keep_the_top_of_their_range() -> None:
    codec = _codec(RANGE, ("step", "step", "from_value"), (3,), "uint64")
    # The same field twice: the last element wins, as with any repeated path.
    message, _ = _roundtrip(codec, [1, 2**64 - 1, 2**53 + 1], "uint64")
    assert message.step == 2**64 - 1
    assert message.from_value == 2**53 + 1


def test_a_nested_message_of_integers_is_filled_and_read_as_integers() -> None:
    codec = _codec("std_msgs/msg/Header", ("stamp",), (2,), "int64")
    message, decoded = _roundtrip(codec, [2**31 - 1, 999_999_999], "int64")
    assert (message.stamp.sec, message.stamp.nanosec) == (2**31 - 1, 999_999_999)
    # int32 and uint32 members: one integer dtype holding both, not float64.
    assert decoded.dtype.kind == "i"
    assert decoded.tolist() == [2**31 - 1, 999_999_999]


def test_an_int64_array_field_is_exact() -> None:
    values = [2**63 - 1, -(2**63), 2**53 + 1]
    codec = _codec("std_msgs/msg/Int64MultiArray", ("data",), (3,), "int64")
    message, decoded = _roundtrip(codec, values, "int64")
    assert message.data.tolist() == values
    assert decoded.tolist() == values


def test_values_that_fit_a_narrower_field_pass() -> None:
    codec = _codec("std_msgs/msg/Int8MultiArray", ("data",), (4,), "float64")
    # A float's fraction is cut off, as a cast does (the compiler warns with W060).
    _, decoded = _roundtrip(codec, [127.9, -128.5, 0.0, -3.0], "float64")
    assert decoded.tolist() == [127, -128, 0, -3]
    codec = _codec("std_msgs/msg/UInt8", ("data",), (), "int64")
    assert _roundtrip(codec, 255, "int64")[1].tolist() == [255]


@pytest.mark.parametrize(
    ("msgtype", "paths", "shape", "dtype", "value", "field", "shown"),
    [
        # scalar field: was struct.error
        ("std_msgs/msg/Int32", ("data",), (), "int64", 2**40, "data", "1099511627776"),
        ("std_msgs/msg/Int64", ("data",), (), "uint64", 2**64 - 1, "data", str(2**64 - 1)),
        ("std_msgs/msg/UInt8", ("data",), (), "int64", -1, "data", "-1"),
        ("std_msgs/msg/Int16", ("data",), (), "float64", float("nan"), "data", "nan"),
        # array field: was wrapped silently
        ("std_msgs/msg/Int32MultiArray", ("data",), (2,), "int64", [1, 2**40], "data",
         "1099511627776"),
        ("std_msgs/msg/Int64MultiArray", ("data",), (2,), "uint64", [0, 2**63], "data",
         str(2**63)),
        ("std_msgs/msg/UInt16MultiArray", ("data",), (2,), "int32", [-5, 3], "data", "-5"),
        ("std_msgs/msg/Int8MultiArray", ("data",), (2,), "float64", [1.0, 128.0], "data",
         "128.0"),
        ("std_msgs/msg/Int64MultiArray", ("data",), (1,), "float64", [float("inf")], "data",
         "inf"),
        ("std_msgs/msg/Int64MultiArray", ("data",), (1,), "float64", [2.0**63], "data",
         str(2.0**63)),
        # elements and nested messages
        (RANGE, ELEMENTS, (3,), "uint64", [2**63, 0, 0], "from_value", str(2**63)),
        (RANGE, ELEMENTS, (3,), "int64", [0, 0, -1], "step", "-1"),
        ("std_msgs/msg/Header", ("stamp",), (2,), "int64", [2**31, 0], "stamp.sec",
         str(2**31)),
        ("std_msgs/msg/Header", ("stamp",), (2,), "int64", [0, -1], "stamp.nanosec", "-1"),
    ],
)  # fmt: skip
def test_a_value_the_field_cannot_hold_is_a_fault_naming_port_field_and_value(
    msgtype: str,
    paths: tuple[str, ...],
    shape: tuple[int, ...],
    dtype: str,
    value: Any,
    field: str,
    shown: str,
) -> None:
    codec = _codec(msgtype, paths, shape, dtype)
    with pytest.raises(RunError) as caught:
        codec.encode({"y": np.array(value, dtype=dtype)})
    assert caught.value.port == "y"
    text = str(caught.value)
    assert f"port `y` sends {shown}," in text
    assert f"field `{field}` of `{msgtype}`" in text
