"""Raw CDR transport on Cyclone DDS: one participant per process, bytes in, bytes out.

Samples are serialised by :mod:`.messages` (rosbags, bulk copies for primitive arrays) and
handed to Cyclone as bytes through the ``cyclonedds`` package's C layer (``ddspy_write`` /
``ddspy_take``, what ``DataWriter.write``/``DataReader.take`` call after their own
per-element serialiser). That keeps a 640x480 image write near one memory copy instead of
30 ms of Python packing, and leaves decoding to the reader. Topics are still created with the
generated IDL types (:mod:`.idl`) so that DDS sees ROS 2's type names and type information.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from cyclonedds._clayer import ddspy_take, ddspy_write, ddspy_write_ts
from cyclonedds.core import DDSException, InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.core import WaitSet as _WaitSet
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from fmionnx.backends.ros2.env import DdsEnvironment
from fmionnx.backends.ros2.idl import idl_type
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability
from fmionnx.core.errors import FmionnxError

_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any


def cyclone_qos(profile: QosProfile) -> Qos:
    """The Cyclone DDS QoS of a writer or reader with ``profile``.

    The reliable max-blocking-time is rmw_cyclonedds_cpp's (100 ms would drop nothing on
    loopback either, but a writer blocks when a reader's queue is full).
    """
    reliability = (
        Policy.Reliability.Reliable(duration(milliseconds=100))
        if profile.reliability is Reliability.RELIABLE
        else Policy.Reliability.BestEffort
    )
    durability = (
        Policy.Durability.TransientLocal
        if profile.durability is Durability.TRANSIENT_LOCAL
        else Policy.Durability.Volatile
    )
    history = Policy.History.KeepAll if profile.keep_all else Policy.History.KeepLast(profile.depth)
    return Qos(reliability, durability, history)


class TransportError(FmionnxError):
    """Cyclone DDS refused to create an entity or to write."""


#: One Domain object per domain id and process (Cyclone allows one configuration per domain).
_DOMAINS: dict[int, tuple[Domain, str]] = {}


def _domain(env: DdsEnvironment) -> Domain:
    config = env.cyclone_config()
    known = _DOMAINS.get(env.domain_id)
    if known is not None:
        if known[1] != config:
            msg = (
                f"DDS domain {env.domain_id} is already open in this process with another "
                "configuration"
            )
            raise TransportError(msg)
        return known[0]
    try:
        domain = Domain(env.domain_id, config)
    except DDSException as exc:
        msg = f"cannot create DDS domain {env.domain_id}: {exc} (check CYCLONEDDS_URI)"
        raise TransportError(msg) from None
    _DOMAINS[env.domain_id] = (domain, config)
    return domain


def gid_of(entity: Any) -> bytes:
    """The 16-byte DDS GUID of a participant, writer or reader (a ROS 2 GID's content)."""
    return bytes(entity.guid.bytes)


def wait_for_matches(matched: Callable[[], int], count: int, timeout: float) -> bool:
    """Poll ``matched()`` until it reaches ``count``; False after ``timeout`` seconds.

    Matching is reported by discovery threads, not as an event a writer could wait on.
    """
    deadline = time.monotonic() + timeout
    while matched() < count:
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


@dataclass
class RawWriter:
    """A DDS writer that publishes already serialised CDR samples."""

    writer: DataWriter[Any]
    topic: str
    msgtype: str

    @property
    def gid(self) -> bytes:
        """The writer's GUID."""
        return gid_of(self.writer)

    def write(self, data: bytes, stamp_ns: int | None = None) -> None:
        """Publish one sample (CDR with encapsulation header), padded to 4 bytes as DDS wants.

        ``stamp_ns`` becomes the sample's DDS source timestamp (``dds_write_ts``); DDS times
        cannot be negative, so a negative stamp leaves the timestamp to Cyclone's clock.
        """
        padding = -len(data) % 4
        if padding:
            data += b"\0" * padding
        if stamp_ns is not None and stamp_ns >= 0:
            ret = ddspy_write_ts(self.writer._ref, data, stamp_ns)
        else:
            ret = ddspy_write(self.writer._ref, data)
        if ret < 0:
            msg = f"writing to {self.topic} failed (DDS return code {ret})"
            raise TransportError(msg)

    def matched(self) -> int:
        """Number of readers matched right now.

        Read from the writer's matched status (one call). Cyclone's Python binding lists the
        matched readers in two calls, a count and then that many handles, and failed with an
        ``IndexError`` when a reader matched in between (a node of a starting run faulted so,
        once in a CI run)."""
        status: Any = self.writer.get_publication_matched_status  # untyped in the binding
        return int(status().current_count)

    def wait_for_readers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Wait until ``count`` readers matched (samples written before are lost to them)."""
        return wait_for_matches(self.matched, count, timeout)


@dataclass
class RawReader:
    """A DDS reader that hands out samples as CDR bytes (with encapsulation header)."""

    reader: DataReader[Any]
    topic: str
    msgtype: str
    participant: DomainParticipant
    _waitset: _WaitSet | None = field(default=None, repr=False)

    @property
    def gid(self) -> bytes:
        """The reader's GUID."""
        return gid_of(self.reader)

    def take(self, limit: int = 64) -> list[bytes]:
        """Every valid sample waiting (up to ``limit``), oldest first; never blocks."""
        result = ddspy_take(self.reader._ref, _ANY_STATE, limit)
        if isinstance(result, int):
            msg = f"reading {self.topic} failed (DDS return code {result})"
            raise TransportError(msg)
        return [bytes(data) for data, info in result if info.valid_data]

    def take_stamped(self, limit: int = 64) -> list[tuple[bytes, int | None]]:
        """Like :meth:`take`, with each sample's DDS source timestamp in ns."""
        result = ddspy_take(self.reader._ref, _ANY_STATE, limit)
        if isinstance(result, int):
            msg = f"reading {self.topic} failed (DDS return code {result})"
            raise TransportError(msg)
        return [
            (bytes(data), int(info.source_timestamp)) for data, info in result if info.valid_data
        ]

    def wait(self, timeout: float) -> bool:
        """Block until a sample is available or ``timeout`` seconds passed; True when data."""
        if self._waitset is None:
            self._waitset = _WaitSet(self.participant)
            self._waitset.attach(ReadCondition(self.reader, _ANY_STATE))
        return self._waitset.wait(duration(seconds=max(timeout, 0.0))) > 0

    def matched(self) -> int:
        """Number of writers matched right now (the reader's matched status: one call, see
        :meth:`RawWriter.matched`)."""
        status: Any = self.reader.get_subscription_matched_status  # untyped in the binding
        return int(status().current_count)


class Participant:
    """One DDS participant that looks like a ROS 2 context (``enclave=/;`` in USER_DATA)."""

    def __init__(self, env: DdsEnvironment, *, enclave: str = "/") -> None:
        self.env = env
        self.distro: RosDistro = env.distro
        self._domain = _domain(env)
        user_data = f"enclave={enclave};".encode()
        try:
            self.dp = DomainParticipant(env.domain_id, qos=Qos(Policy.Userdata(user_data)))
        except DDSException as exc:
            msg = f"cannot create a DDS participant on domain {env.domain_id}: {exc}"
            raise TransportError(msg) from None
        self._topics: dict[str, Topic[Any]] = {}

    @property
    def gid(self) -> bytes:
        """The participant's GUID."""
        return gid_of(self.dp)

    def _topic(self, dds_name: str, msgtype: str) -> Topic[Any]:
        topic = self._topics.get(dds_name)
        if topic is None:
            topic = Topic(self.dp, dds_name, idl_type(msgtype, self.distro))
            self._topics[dds_name] = topic
        return topic

    def writer(self, dds_name: str, msgtype: str, qos: QosProfile) -> RawWriter:
        """A raw writer on DDS topic ``dds_name`` (``rt/...``)."""
        writer = DataWriter(self.dp, self._topic(dds_name, msgtype), qos=cyclone_qos(qos))
        return RawWriter(writer, dds_name, msgtype)

    def reader(self, dds_name: str, msgtype: str, qos: QosProfile) -> RawReader:
        """A raw reader on DDS topic ``dds_name``."""
        reader = DataReader(self.dp, self._topic(dds_name, msgtype), qos=cyclone_qos(qos))
        return RawReader(reader, dds_name, msgtype, self.dp)

    def close(self) -> None:
        """Delete the participant and everything it owns (readers, writers, topics)."""
        self._topics.clear()
        self.dp.__del__()  # cyclonedds deletes the C entity in __del__; do it now.

    def __enter__(self) -> Participant:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
