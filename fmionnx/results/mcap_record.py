"""``--record FILE.mcap``: camera frames and signals in one file Foxglove opens directly.

Frames are ROS 2 ``sensor_msgs/msg/Image`` (CDR, ``rgb8``) on ``/<component>/<camera>``,
serialized with rosbags' ROS 2 Humble type store and written as they are rendered, so memory
stays flat however long the run. Signals go to ``/signals`` as JSON objects (``time`` plus
one field per results column, plottable by message path in Foxglove), written at the end from
the recorded columns, at most :data:`MAX_SIGNAL_RATE` messages per simulated second.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path
from typing import IO, Any

import numpy as np

from fmionnx.runtime.result import RunResult

#: Signals are thinned to at most this many messages per simulated second.
MAX_SIGNAL_RATE = 100.0
IMAGE_TYPE = "sensor_msgs/msg/Image"


def _stamp(time: float) -> tuple[int, int, int]:
    """(sec, nanosec, log_time ns) of a simulated time >= 0."""
    ns = round(time * 1e9)
    return ns // 1_000_000_000, ns % 1_000_000_000, ns


class McapRecorder:
    """A frame sink (see ``FrameSink``) writing an MCAP file; close with :meth:`finish`."""

    def __init__(self, path: Path) -> None:
        from mcap.writer import Writer
        from rosbags.typesys import Stores, get_typestore

        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        # Recorded into a fresh file beside ``path`` and renamed over it by ``finish``: a link
        # planted at ``path`` is replaced, never written through, and no half file appears.
        descriptor, name = tempfile.mkstemp(
            prefix=f".{path.name}.", suffix=".part", dir=path.parent
        )
        self._partial = Path(name)
        self._stream: IO[bytes] = os.fdopen(descriptor, "wb")
        self._writer: Any = Writer(self._stream)
        self._writer.start(profile="ros2", library="fmionnx")
        self._store: Any = get_typestore(Stores.ROS2_HUMBLE)
        text, _ = self._store.generate_msgdef(IMAGE_TYPE, ros_version=2)
        self._image_schema = self._writer.register_schema(
            name=IMAGE_TYPE, encoding="ros2msg", data=text.encode()
        )
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self.frames = 0

    def _channel(self, topic: str) -> int:
        if topic not in self._channels:
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=self._image_schema
            )
        return self._channels[topic]

    def frame(self, component: str, port: str, time: float, image: Any) -> None:
        """Write one RGB frame (``uint8[H,W,3]``) as a ROS 2 Image message."""
        store = self._store
        sec, nanosec, log_time = _stamp(time)
        height, width = int(image.shape[0]), int(image.shape[1])
        types = store.types
        header = types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
            frame_id=f"{component}/{port}",
        )
        message = types[IMAGE_TYPE](
            header=header,
            height=height,
            width=width,
            encoding="rgb8",
            is_bigendian=0,
            step=width * 3,
            data=np.ascontiguousarray(image, dtype=np.uint8).reshape(-1),
        )
        data = store.serialize_cdr(message, IMAGE_TYPE)
        self._writer.add_message(
            channel_id=self._channel(f"/{component}/{port}"),
            log_time=log_time,
            publish_time=log_time,
            data=bytes(data),
            sequence=self._sequence,
        )
        self._sequence += 1
        self.frames += 1

    def finish(self, result: RunResult | None) -> Path:
        """Write the signals of ``result`` (if any) and close the file."""
        if result is not None and result.signals:
            self._signals(result)
        self._writer.finish()
        self._stream.close()
        self._partial.chmod(0o644)
        self._partial.replace(self.path)
        return self.path

    def _signals(self, result: RunResult) -> None:
        names = list(result.signals)
        schema = {
            "type": "object",
            "properties": {"time": {"type": "number"}, **{n: {"type": "number"} for n in names}},
        }
        schema_id = self._writer.register_schema(
            name="fmionnx.Signals", encoding="jsonschema", data=json.dumps(schema).encode()
        )
        channel = self._writer.register_channel(
            topic="/signals", message_encoding="json", schema_id=schema_id
        )
        stride = max(1, math.ceil(1.0 / (MAX_SIGNAL_RATE * result.step)))
        columns = [result.signals[n] for n in names]
        for row in range(0, result.time.size, stride):
            time = float(result.time[row])
            payload: dict[str, float | None] = {"time": time}
            payload.update({n: _finite(float(c[row])) for n, c in zip(names, columns, strict=True)})
            _, _, log_time = _stamp(max(time, 0.0))
            self._writer.add_message(
                channel_id=channel,
                log_time=log_time,
                publish_time=log_time,
                data=json.dumps(payload).encode(),
                sequence=self._sequence,
            )
            self._sequence += 1


def _finite(value: float) -> float | None:
    """JSON has no NaN/Inf; they become null."""
    return value if math.isfinite(value) else None
