"""Integer ports over ROS 2: their own std_msgs type, so 64-bit values arrive bit for bit.

A ``std_msgs/msg/Float64`` holds integers only up to 2**53: an ``int64`` or ``uint64`` output
sent that way reached its reader rounded (and a ``uint64`` near 2**64 wrapped to 0), so a
lockstep run differed from the in-process one. Checked on the real wire: two Types3 FMUs
(compiled from C) chained by their 64-bit ports, as node processes over Cyclone DDS and over
the rmw_zenoh wire.
"""

from __future__ import annotations

import csv
import subprocess
from pathlib import Path

import numpy as np
import pytest

from fmionnx.backends.ros2.codec import TopicCodec
from fmionnx.compile.ros2.fields import PortField
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.plan import default_type
from fmionnx.core.types import Causality, DType, Port
from tests.conftest import build_fixture_fmu
from tests.ros2.test_run import fmionnx

pytestmark = pytest.mark.ros2

#: a.y_i64 = 3*u_i64 + 1 = 2**53 + 5 and a.y_u64 = u_u64 + 2**40 = 2**64 - 1: neither is a
#: float64, and b's outputs (3*x + 1, x + 2**40) make a rounded input visible.
CHAIN = """
fmionnx: 1
name: t3chain
run: {{stop: 0.2, step: 0.1}}
components:
  a: {{kind: fmu, path: {fmu}, parameters: {{u_i64: 3002399751580332,
      u_u64: 18446742974197923839, u_i32: 2147483647}}}}
  b: {{kind: fmu, path: {fmu}}}
connections:
  - a.y_i64 -> b.u_i64
  - a.y_u64 -> b.u_u64
  - a.y_i32 -> b.u_i32
  - a.y_u32 -> b.u_u32
"""


@pytest.mark.parametrize(
    ("dtype", "shape", "expected"),
    [
        (DType.INT64, (), "std_msgs/msg/Int64"),
        (DType.UINT64, (), "std_msgs/msg/UInt64"),
        (DType.INT8, (), "std_msgs/msg/Int8"),
        (DType.UINT16, (), "std_msgs/msg/UInt16"),
        (DType.INT32, (3,), "std_msgs/msg/Int32MultiArray"),
        (DType.UINT8, (4,), "std_msgs/msg/UInt8MultiArray"),
        (DType.UINT8, (2, 3, 3), "sensor_msgs/msg/Image"),
        (DType.FLOAT32, (), "std_msgs/msg/Float64"),
        (DType.BOOL, (2,), "std_msgs/msg/Float64MultiArray"),
    ],
)
def test_integer_ports_default_to_the_std_msgs_type_of_their_width(
    dtype: DType, shape: tuple[int, ...], expected: str
) -> None:
    assert default_type(Port("p", Causality.OUTPUT, dtype, shape)) == expected


@pytest.mark.parametrize(
    ("msgtype", "dtype", "value"),
    [
        ("std_msgs/msg/Int64", "int64", 2**63 - 1),
        ("std_msgs/msg/Int64", "int64", -(2**53) - 3),
        ("std_msgs/msg/UInt64", "uint64", 2**64 - 1),
    ],
)
def test_a_64_bit_value_survives_encode_and_decode(msgtype: str, dtype: str, value: int) -> None:
    codec = TopicCodec(msgtype, (PortField("y", ("data",), (), dtype),), RosDistro.JAZZY)
    decoded, _ = codec.decode(codec.encode({"y": np.array(value, dtype=dtype)}))
    assert decoded["y"].dtype == np.dtype(dtype)
    assert int(decoded["y"][0]) == value


def _column(results: Path, name: str) -> list[str]:
    with results.open(newline="") as stream:
        return [row[name] for row in csv.DictReader(stream)]


@pytest.mark.parametrize("middleware", ["dds", "zenoh"])
def test_lockstep_hands_64_bit_integers_on_exactly_as_inprocess(
    tmp_path: Path, loopback_env, monkeypatch: pytest.MonkeyPatch, middleware: str
) -> None:
    if middleware == "zenoh":
        from fmionnx.backends.ros2.zenoh.router import free_port

        # A router of this run's own (started by the supervisor), never a real one on 7447.
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", f'connect/endpoints=["{endpoint}"]')
        monkeypatch.delenv("ZENOH_SESSION_CONFIG_URI", raising=False)
    system = tmp_path / "t3chain.yaml"
    system.write_text(CHAIN.format(fmu=build_fixture_fmu("Types3")), encoding="utf-8")
    inprocess, ros2 = tmp_path / "inprocess", tmp_path / "ros2"
    subprocess.run(fmionnx("run", system, "-q", "--out", inprocess), check=True, timeout=60)
    done = subprocess.run(
        fmionnx("run", system, "-q", "--backend", "ros2", "--middleware", middleware,
                "--out", ros2),
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    expected, got = inprocess / "results.csv", ros2 / "results.csv"
    # b's outputs are computed from what b received: the values a sent, not float64 roundings.
    for column in ("b.y_i64", "b.y_u64", "b.y_i32", "b.y_u32"):
        assert _column(got, column) == _column(expected, column), column
    assert _column(got, "b.y_u64")[-1] == str(2**40 - 1)  # (2**64 - 1) + 2**40 wraps
    assert got.read_bytes() == expected.read_bytes()
