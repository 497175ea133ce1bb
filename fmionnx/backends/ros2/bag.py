"""``fmionnx run --backend ros2 --record FILE.mcap``: a rosbag2-style recording of the wire.

The supervisor subscribes to every topic of the plan (the nodes' topics, topics expected from
outside, and ``/clock``) and writes each sample exactly as it crossed the wire (DDS or Zenoh):
the CDR bytes with their encapsulation header, ``cdr`` message encoding, one ``ros2msg`` schema
per type (the definition text from the distribution's rosbags type store, dependencies included,
as rosbag2 writes it). That is what ``ros2 bag record`` produces, so ``ros2 bag info/play`` and Foxglove
open the file; nothing is re-encoded, so the bag also proves what the nodes really sent.

``log_time`` is the receive time on the system clock (rosbag2's default), ``publish_time`` the
same. Signals are not duplicated into the bag: they are in ``results.csv``.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from fmionnx.backends.ros2.middleware import NodeTransport, SampleReader
from fmionnx.compile.ros2.messages import typestore
from fmionnx.compile.ros2.names import dds_topic
from fmionnx.compile.ros2.plan import CLOCK_TOPIC, CLOCK_TYPE
from fmionnx.compile.ros2.qos import QosProfile
from fmionnx.compile.ros2.types import Ros2Plan
from fmionnx.core.safewrite import open_growing

#: Seconds between two sweeps over the readers; reader queues hold what arrives meanwhile.
POLL = 0.002
#: Reader history: deep enough that a 30 Hz camera never overruns between two sweeps.
DEPTH = 100


@dataclass(frozen=True, slots=True)
class RecordedTopic:
    """One topic in the bag: its reader and MCAP channel."""

    name: str
    reader: SampleReader
    channel: int


class TopicRecorder:
    """Records every planned topic into an MCAP file until :meth:`close`.

    Readers are created at once (before the nodes start, so nothing is missed); a background
    thread drains them. ``close`` drains one last time and finishes the file.
    """

    def __init__(self, path: Path, plan: Ros2Plan, participant: NodeTransport) -> None:
        from mcap.writer import Writer

        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.messages = 0
        self._stream: IO[bytes] = open_growing(path)
        self._writer: Any = Writer(self._stream)
        self._writer.start(profile="ros2", library="fmionnx")
        self._store = typestore(plan.distro)
        self._schemas: dict[str, int] = {}
        self._sequence = 0
        self._lock = threading.Lock()
        topics = [(t.name, t.msgtype, t.qos) for t in plan.topics]
        if all(name != CLOCK_TOPIC for name, _, _ in topics):
            topics.append((CLOCK_TOPIC, CLOCK_TYPE, QosProfile()))
        self.topics = [self._subscribe(participant, *topic) for topic in topics]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="fmionnx-record", daemon=True)
        self._thread.start()

    def _schema(self, msgtype: str) -> int:
        if msgtype not in self._schemas:
            text, _ = self._store.generate_msgdef(msgtype, ros_version=2)
            self._schemas[msgtype] = self._writer.register_schema(
                name=msgtype, encoding="ros2msg", data=text.encode()
            )
        return self._schemas[msgtype]

    def _subscribe(
        self, participant: NodeTransport, name: str, msgtype: str, qos: QosProfile
    ) -> RecordedTopic:
        # Same reliability and durability as the writers (so it matches them), deeper queue.
        profile = QosProfile(qos.reliability, qos.durability, max(qos.depth, DEPTH), qos.keep_all)
        reader = participant.reader(dds_topic(name), msgtype, profile)
        channel = self._writer.register_channel(
            topic=name, message_encoding="cdr", schema_id=self._schema(msgtype)
        )
        return RecordedTopic(name, reader, channel)

    def _drain(self) -> int:
        count = 0
        with self._lock:
            for topic in self.topics:
                for data in topic.reader.take(256):
                    now = time.time_ns()
                    self._writer.add_message(
                        channel_id=topic.channel,
                        log_time=now,
                        publish_time=now,
                        data=data,
                        sequence=self._sequence,
                    )
                    self._sequence += 1
                    count += 1
            self.messages += count
        return count

    def _loop(self) -> None:
        while not self._stop.is_set():
            if not self._drain():
                self._stop.wait(POLL)

    def close(self) -> Path:
        """Stop recording, write what is still queued and finish the file."""
        self._stop.set()
        self._thread.join()
        self._drain()
        self._writer.finish()
        self._stream.close()
        return self.path
