"""``--record FILE.mcap``: camera frames, signals, the course and the checks in one file
Foxglove opens directly.

The channels are :mod:`.channels`' (the Foxglove live view publishes the same): frames are
ROS 2 ``sensor_msgs/msg/Image`` (CDR, ``rgb8``) on ``/<component>/<camera>``, written as
they are rendered, so memory stays flat however long the run. At the end come the signals
(``/signals``, JSON, at most :data:`~.channels.MAX_SIGNAL_RATE` rows per simulated second,
from the recorded columns), the dataflow graph (``/graph``) and, for a system with an xy
plot, its course (``/map``) and the trajectory (``/trajectory``, the path so far once per
simulated second), and the checks' verdicts (``/checks``).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from fmionnx.results import channels as ch
from fmionnx.runtime.result import RunResult

if TYPE_CHECKING:
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.runtime.checks import CheckOutcome

MAX_SIGNAL_RATE = ch.MAX_SIGNAL_RATE
IMAGE_TYPE = ch.IMAGE_TYPE


class McapRecorder:
    """A frame sink (see ``FrameSink``) writing an MCAP file; close with :meth:`finish`."""

    def __init__(self, path: Path, system: CompiledSystem | None = None) -> None:
        from mcap.writer import Writer

        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.system = system
        # Recorded into a fresh file beside ``path`` and renamed over it by ``finish``: a link
        # planted at ``path`` is replaced, never written through, and no half file appears.
        descriptor, name = tempfile.mkstemp(
            prefix=f".{path.name}.", suffix=".part", dir=path.parent
        )
        self._partial = Path(name)
        self._stream: IO[bytes] = os.fdopen(descriptor, "wb")
        self._writer: Any = Writer(self._stream)
        self._writer.start(profile="ros2", library="fmionnx")
        self._images = ch.ImageCodec()
        self._schemas: dict[tuple[str, str, bytes], int] = {}
        self._channels: dict[str, int] = {}
        self._sequence = 0
        self.frames = 0

    def _channel(self, spec: ch.ChannelSpec) -> int:
        """The id of ``spec``'s channel (registered, with its schema, on first use)."""
        found = self._channels.get(spec.topic)
        if found is not None:
            return found
        key = (spec.schema_name, spec.schema_encoding, spec.schema)
        schema = self._schemas.get(key)
        if schema is None:
            schema = self._writer.register_schema(
                name=spec.schema_name, encoding=spec.schema_encoding, data=spec.schema
            )
            self._schemas[key] = schema
        channel = self._writer.register_channel(
            topic=spec.topic, message_encoding=spec.message_encoding, schema_id=schema
        )
        self._channels[spec.topic] = channel
        return int(channel)

    def _write(self, spec: ch.ChannelSpec, time: float, data: bytes) -> None:
        _, _, log_time = ch.stamp(time)
        self._writer.add_message(
            channel_id=self._channel(spec),
            log_time=log_time,
            publish_time=log_time,
            data=data,
            sequence=self._sequence,
        )
        self._sequence += 1

    def frame(self, component: str, port: str, time: float, image: Any) -> None:
        """Write one RGB frame (``uint8[H,W,3]``) as a ROS 2 Image message."""
        data = self._images.encode(component, port, time, image)
        self._write(self._images.channel(component, port), time, data)
        self.frames += 1

    def finish(self, result: RunResult | None, checks: Sequence[CheckOutcome] = ()) -> Path:
        """Write the signals, course, trajectory, graph and checks of ``result`` (if any) and
        close the file."""
        if result is not None:
            if self.system is not None:
                self._system(result, checks)
            if result.signals:
                self._signals(result)
        self._writer.finish()
        self._stream.close()
        self._partial.chmod(0o644)
        self._partial.replace(self.path)
        return self.path

    def _system(self, result: RunResult, checks: Sequence[CheckOutcome]) -> None:
        system = self.system
        assert system is not None
        start, end = result.start, result.start + result.simulated_time
        self._write(ch.graph_channel(), start, ch.encode_graph(system))
        plot = ch.map_plot(system)
        if plot is not None:
            self._write(ch.map_channel(), start, ch.encode_map(start, plot))
            self._trajectory(result, plot.series[0].columns[0], plot.series[1].columns[0])
        if checks:
            self._write(ch.checks_channel(), end, ch.encode_checks(end, checks))

    def _trajectory(self, result: RunResult, x: str, y: str) -> None:
        """The path so far once per simulated second (and at the end), each thinned to
        :data:`~.channels.TRAJECTORY_RATE` points a second."""
        if x not in result.signals or y not in result.signals:
            return
        time = result.time
        keep = np.arange(0, time.size, ch.trajectory_stride(result.step * _spacing(result)))
        xs, ys = result.signals[x], result.signals[y]
        every = max(1, round(1.0 / (time[1] - time[0]))) if time.size > 1 else 1
        marks = sorted({*range(0, time.size, every), time.size - 1})
        for row in marks:
            upto = keep[keep <= row]
            data = ch.encode_trajectory(float(time[row]), xs[upto].tolist(), ys[upto].tolist())
            self._write(ch.trajectory_channel(), float(time[row]), data)

    def _signals(self, result: RunResult) -> None:
        names = list(result.signals)
        spec = ch.signals_channel(names)
        stride = max(1, ch.signal_stride(result.step) // _spacing(result))
        columns = [result.signals[n] for n in names]
        for row in range(0, result.time.size, stride):
            time = float(result.time[row])
            values = {n: float(c[row]) for n, c in zip(names, columns, strict=True)}
            self._write(spec, max(time, 0.0), ch.encode_signals(time, values))


def _spacing(result: RunResult) -> int:
    """Base steps between two rows of ``result`` (its output interval's, else 1)."""
    if result.time.size < 2 or result.steps_done == 0:
        return 1
    spacing: float = (result.time[1] - result.time[0]) / result.step
    return max(1, round(spacing))
