"""``--view foxglove``: the run served live over Foxglove's WebSocket protocol (localhost).

The channels, their schemas and their bytes are :mod:`fmionnx.results.channels`', the ones
``--record run.mcap`` writes: open ``ws://127.0.0.1:8765`` in Foxglove (Open connection,
Foxglove WebSocket) and the same layout shows the live run and, later, its recording. Frames
go out as they are rendered, rows at most 100 per simulated second as the run hands them on;
the map and the graph are sent again every :data:`REPEAT` seconds of wall time, for a client
that connects while the run goes (the protocol keeps no message for late subscribers). Every
channel is made before the server starts (:func:`fmionnx.results.channels.planned`), so a
client learns of all of them when it connects. The server stops when the run has ended and
its checks are sent.
"""

from __future__ import annotations

import socket
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import foxglove

from fmionnx.pipeline.errors import RefusedError
from fmionnx.pipeline.observers import Rows, RunObserver, RunStart
from fmionnx.pipeline.views.course import Course
from fmionnx.results import channels as ch

if TYPE_CHECKING:
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.pipeline.outcome import RunOutcome

#: Seconds of wall time between two sendings of what does not change (map, graph).
REPEAT = 1.0
#: Seconds the server stays up after the last message (the socket drains its queue).
LINGER = 0.3
#: Seconds a stopped server's port is waited for (:func:`_released`).
RELEASE_WAIT = 5.0


class FoxgloveView(RunObserver):
    """Serves a run on Foxglove's WebSocket protocol (module docstring)."""

    wants_feed = True

    def __init__(self, port: int) -> None:
        self.port = port
        self._context: Any = None
        self._server: Any = None
        self._channels: dict[str, Any] = {}
        self._images: ch.ImageCodec | None = None
        self._course: Course | None = None
        self._system: CompiledSystem | None = None
        self._repeated = 0.0
        self._time = 0.0

    def before_run(self, start: RunStart) -> None:
        """Start the server on localhost; name its address on stderr."""
        system = start.system.compiled
        self._system = system
        self._context = foxglove.Context()
        self._images = ch.ImageCodec()
        for spec in ch.planned(system, self._images, start.system.record):
            self._channel(spec)  # before the server: a client is told of every channel at once
        try:
            self._server = foxglove.start_server(
                name=f"fmionnx {system.name}", host="127.0.0.1", port=self.port,
                context=self._context,
            )  # fmt: skip
        except Exception as exc:  # the SDK's own error type (a port in use, say)
            msg = (
                f"--view foxglove: cannot serve on 127.0.0.1:{self.port} ({exc}); choose another "
                "port with --view foxglove:PORT (0: any free one)"
            )
            raise RefusedError(msg) from None
        self._course = Course(system)
        self._time = system.run.start
        print(f"foxglove: serving ws://127.0.0.1:{self._server.port}", file=sys.stderr, flush=True)
        self._statics()

    @property
    def address(self) -> str | None:
        """The server's address while it runs."""
        return None if self._server is None else f"ws://127.0.0.1:{self._server.port}"

    def _channel(self, spec: ch.ChannelSpec) -> Any:
        found = self._channels.get(spec.topic)
        if found is None:
            schema = foxglove.Schema(
                name=spec.schema_name, encoding=spec.schema_encoding, data=spec.schema
            )
            found = foxglove.Channel(
                spec.topic, schema=schema, message_encoding=spec.message_encoding,
                context=self._context,
            )  # fmt: skip
            self._channels[spec.topic] = found
        return found

    def _log(self, spec: ch.ChannelSpec, time_: float, data: bytes) -> None:
        _, _, log_time = ch.stamp(time_)
        self._channel(spec).log(data, log_time=log_time)

    def _statics(self) -> None:
        """The graph and the map, stamped with the newest simulated time."""
        system, course = self._system, self._course
        assert system is not None
        self._log(ch.graph_channel(), self._time, ch.encode_graph(system))
        if course is not None and course.plot is not None:
            self._log(ch.map_channel(), self._time, ch.encode_map(self._time, course.plot))
        self._repeated = time.perf_counter()

    def frame(self, component: str, port: str, time_: float, image: Any) -> None:
        """Send one camera frame."""
        codec = self._images
        assert codec is not None
        self._log(
            codec.channel(component, port), time_, codec.encode(component, port, time_, image)
        )

    def rows(self, rows: Rows) -> None:
        """Send each row on ``/signals``, then the path so far."""
        names = list(rows.columns)
        spec = ch.signals_channel(names)
        columns = [rows.columns[n] for n in names]
        for i, time_ in enumerate(rows.time.tolist()):
            values = {n: float(c[i]) for n, c in zip(names, columns, strict=True)}
            self._log(spec, time_, ch.encode_signals(time_, values))
        self._time = float(rows.time[-1])
        course = self._course
        if course is not None and course.add(rows):
            data = ch.encode_trajectory(self._time, course.xs, course.ys)
            self._log(ch.trajectory_channel(), self._time, data)
        if time.perf_counter() - self._repeated >= REPEAT:
            self._statics()

    def finished(self, outcome: RunOutcome) -> None:
        """Send the checks, then stop the server."""
        if self._server is None:
            return
        result = outcome.result
        end = result.start + result.simulated_time
        if outcome.checks:
            self._log(ch.checks_channel(), end, ch.encode_checks(end, outcome.checks))
        self.close()

    def abandoned(self, result: Any, out: Path | None) -> None:
        """The process ends right after."""
        self.close()

    def failed(self, error: BaseException) -> None:
        """The run raised: stop the server, so that its port is free for the next run."""
        self.close()

    def close(self) -> None:
        """Stop the server (after a moment for the last messages to leave)."""
        server, self._server = self._server, None
        if server is None:
            return
        time.sleep(LINGER)
        for channel in self._channels.values():
            channel.close()
        port = server.port
        server.stop()
        _released(port)


def _released(port: int, within: float = RELEASE_WAIT) -> None:
    """Wait until the stopped server's ``port`` can be bound again (at most ``within`` s).

    The SDK's ``stop`` only asks its server's thread to end; the socket closes a moment
    later, and a next run in this process that serves on the same port was refused "Address
    already in use" on a loaded machine (CI). The probe binds as a server does (address
    reuse: connections left in TIME_WAIT do not hold the port)."""
    deadline = time.monotonic() + within
    while True:
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                probe.bind(("127.0.0.1", port))
            except OSError:
                if time.monotonic() >= deadline:
                    return  # the next server says so, naming the port
            else:
                return
        time.sleep(0.02)
