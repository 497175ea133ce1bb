"""``--view rerun`` and ``--rrd FILE``: the run in Rerun, on the simulation timeline.

One recording stream per run (application ``fmionnx``, named after the system), sent to a
viewer (spawned on this machine or already running there, or a remote one by its URL) and/or
written to an ``.rrd`` file. Everything is logged on the ``sim_time`` timeline:

==============================  ================================================================
entity                          what
==============================  ================================================================
``<component>/<camera>``        each camera frame as rendered (JPEG-compressed image)
``<component>/<port>``          each recorded scalar signal (``Scalars``); array elements as
                                ``<component>/<port>/<i>``, at most 100 rows a simulated second
``map/landmarks``, ``map/sites``  the scene's shapes and named sites (static), as the
                                trajectory plot draws them; ``map/expected_path`` likewise
``map/trajectory``              the path so far; ``map/position`` where the robot is
``graph``                       the dataflow graph: a node per component, an edge per
                                connection (static)
``checks``, ``checks/<name>``   the checks' table and each verdict, when the run ended
``run``                         how the run ended
==============================  ================================================================

A default blueprint lays them out: the map and each camera beside each other, the graph, a
time series view per component. The ``.rrd`` is written beside its final name and renamed
over it when the run ends, so no half file is left under that name.
"""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import tempfile
import time
import uuid
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from fmionnx.pipeline.observers import Rows, RunObserver, RunStart
from fmionnx.pipeline.views.course import Course
from fmionnx.pipeline.viewspec import RERUN_PORT, ViewTarget
from fmionnx.results.channels import graph_of

if TYPE_CHECKING:
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.pipeline.outcome import RunOutcome

TIMELINE = "sim_time"
#: Seconds the end of a run waits for the viewer to take what was sent.
FLUSH_TIMEOUT = 10.0
#: JPEG quality of logged frames (a raw 640x480 frame is 0.9 MB; compressed about 40 kB).
JPEG_QUALITY = 85


def _listening(host: str, port: int, wait: float) -> bool:
    """Whether ``host:port`` accepts a TCP connection within ``wait`` seconds."""
    deadline = time.monotonic() + wait
    while True:
        try:
            with socket.create_connection((host.strip("[]"), port), timeout=1.0):
                return True
        except OSError:
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.2)


def reach_viewer(target: ViewTarget, wait: float) -> None:
    """Make sure the viewer of ``target`` listens: spawn the local one (or find it running),
    or find the remote one answering; ViewerUnreachableError naming what to do otherwise."""
    from fmionnx.pipeline.views import ViewerUnreachableError

    if target.url is None:
        if not _listening("127.0.0.1", RERUN_PORT, 0.0):
            rr.spawn(port=RERUN_PORT, connect=False)
        if not _listening("127.0.0.1", RERUN_PORT, wait):
            msg = (
                f"--view rerun: the Rerun viewer did not start (nothing listens on port "
                f"{RERUN_PORT} after {wait:g} s; a machine without a display cannot show it): "
                "write a recording with --rrd FILE instead, or connect to a viewer elsewhere "
                "with --view rerun+tcp://HOST:PORT"
            )
            raise ViewerUnreachableError(msg)
        return
    where = target.url.removeprefix("rerun+http://").removesuffix("/proxy")
    host, _, port = where.rpartition(":")
    if not _listening(host, int(port), wait):
        msg = (
            f"--view {target.given or target.url}: no Rerun viewer answers at {host}:{port} "
            "(start one there "
            f"with `rerun`, which listens on port {RERUN_PORT})"
        )
        raise ViewerUnreachableError(msg)


def entity(column: str) -> str:
    """The entity of a results column: ``odometry.posX`` -> ``odometry/posX``,
    ``world.base_pos[1]`` -> ``world/base_pos/1``, a tensor's element
    ``detector.blobX[0,2]`` -> ``detector/blobX/0/2`` (one level per dimension)."""
    component, _, rest = column.partition(".")
    port, _, index = rest.partition("[")
    parts = [component, port, *(index.rstrip("]").split(",") if index else [])]
    return "/".join(rr.escape_entity_path_part(part) for part in parts)


def _rgb(rgba: tuple[float, float, float, float]) -> list[int]:
    return [round(255 * c) for c in rgba[:3]] + [255]


class RerunView(RunObserver):
    """Streams a run to Rerun (module docstring)."""

    wants_feed = True

    def __init__(
        self, target: ViewTarget | None, rrd: Path | None, *, memory: bool = False
    ) -> None:
        self.target = target
        self.rrd = rrd
        #: ``memory``: the recording is kept in memory; :attr:`data` holds its bytes (an
        #: ``.rrd`` file's) once the run has ended (a study's case, made on a worker).
        self.memory = memory
        self.data: bytes | None = None
        self._buffer: Any = None
        self._partial: Path | None = None
        self._stream: Any = None
        self._course: Course | None = None
        self._components: tuple[str, ...] = ()

    # -- the run's hooks -----------------------------------------------------------------------

    def before_run(self, start: RunStart) -> None:
        """Open the stream, send the blueprint and what does not change (graph, map)."""
        system = start.system.compiled
        self._components = tuple(c.name for c in system.components)
        stream = rr.RecordingStream("fmionnx", recording_id=uuid.uuid4())
        sinks: list[Any] = []
        if self.target is not None:  # a viewer found listening (``reach_viewer``)
            url = self.target.url or f"rerun+http://127.0.0.1:{RERUN_PORT}/proxy"
            sinks.append(rr.GrpcSink(url))
        if self.rrd is not None:
            self.rrd.parent.mkdir(parents=True, exist_ok=True)
            descriptor, name = tempfile.mkstemp(
                prefix=f".{self.rrd.name}.", suffix=".part", dir=self.rrd.parent
            )
            os.close(descriptor)
            self._partial = Path(name)
            sinks.append(rr.FileSink(str(self._partial)))
        if self.memory:
            self._buffer = rr.binary_stream(recording=stream)
            stream.send_blueprint(self._blueprint(system))
        else:
            stream.set_sinks(*sinks, default_blueprint=self._blueprint(system))
        stream.send_recording_name(system.name)
        self._stream = stream
        self._course = Course(system)
        self._statics(system)

    def frame(self, component: str, port: str, time: float, image: Any) -> None:
        """Log one camera frame, compressed."""
        stream = self._stream
        stream.set_time(TIMELINE, duration=time)
        stream.log(f"{component}/{port}", rr.Image(image).compress(jpeg_quality=JPEG_QUALITY))

    def rows(self, rows: Rows) -> None:
        """Each column as a time series; the path so far and the current position."""
        stream = self._stream
        index = [rr.TimeColumn(TIMELINE, duration=rows.time)]
        for column, values in rows.columns.items():
            stream.send_columns(entity(column), index, rr.Scalars.columns(scalars=values))
        course = self._course
        if course is not None and course.add(rows):
            path = course.points()
            stream.set_time(TIMELINE, duration=float(rows.time[-1]))
            stream.log("map/trajectory", rr.LineStrips2D([path], colors=[[31, 119, 180]]))
            if len(path):
                stream.log(
                    "map/position", rr.Points2D(path[-1:], radii=0.08, colors=[[214, 39, 40]])
                )

    def finished(self, outcome: RunOutcome) -> None:
        """Log the checks and how the run ended; close the stream (and the ``.rrd``)."""
        stream = self._stream
        if stream is None:
            return
        result = outcome.result
        end = result.start + result.simulated_time
        stream.set_time(TIMELINE, duration=end)
        if outcome.checks:
            lines = ["| check | value | verdict |", "|---|---|---|"]
            for check in outcome.checks:
                verdict = "passed" if check.passed else "FAILED"
                value = "" if check.value is None else f"{check.value:.6g}"
                lines.append(f"| {check.name} | {value} | {verdict} |")
                level = rr.TextLogLevel.INFO if check.passed else rr.TextLogLevel.ERROR
                text = f"{check.name}: {verdict} ({check.expression}; value {value or 'none'})"
                stream.log(
                    f"checks/{rr.escape_entity_path_part(check.name)}",
                    rr.TextLog(text, level=level),
                )
            stream.log("checks", rr.TextDocument("\n".join(lines), media_type="text/markdown"))
        ended = f"{result.status.value} at t={end:g} s" + (
            f": {result.error}" if result.error is not None else ""
        )
        stream.log("run", rr.TextLog(ended, level=rr.TextLogLevel.INFO))
        self.close()

    def abandoned(self, result: Any, out: Path | None) -> None:
        """The process ends right after: keep what was sent."""
        self.close()

    def failed(self, error: BaseException) -> None:
        """The run raised: close the stream; its ``.rrd`` is not written (nothing
        half-written: an earlier recording under the name stays)."""
        self.close(keep=False)

    def close(self, *, keep: bool = True) -> None:
        """Flush and close the stream; the ``.rrd`` takes its name (``keep``), else the
        hidden partial file is removed."""
        stream, self._stream = self._stream, None
        if stream is not None:
            self._flushed(stream)
        partial, self._partial = self._partial, None
        if partial is not None and not keep:
            partial.unlink(missing_ok=True)
        elif partial is not None and self.rrd is not None:
            with contextlib.suppress(FileNotFoundError):
                partial.chmod(0o644)
                partial.replace(self.rrd)

    def _flushed(self, stream: Any) -> None:
        """Flush ``stream`` to its sinks and disconnect it (its bytes to :attr:`data`)."""
        if self._buffer is not None:
            self.data = self._buffer.read(flush=True)
            self._buffer = None
        try:
            stream.flush(timeout_sec=FLUSH_TIMEOUT)
        except RuntimeError as exc:  # the viewer went away during the run: the results stand
            print(f"rerun: not everything reached the viewer: {exc}", file=sys.stderr)
        stream.disconnect()

    # -- what does not change ------------------------------------------------------------------

    def _statics(self, system: CompiledSystem) -> None:
        stream = self._stream
        graph = graph_of(system)
        nodes = [node["id"] for node in graph["nodes"]]
        labels = [f"{node['id']} ({node['kind']})" for node in graph["nodes"]]
        edges = sorted({(edge["from"], edge["to"]) for edge in graph["edges"]})
        stream.log(
            "graph",
            rr.GraphNodes(nodes, labels=labels),
            rr.GraphEdges(edges, graph_type="directed"),
            static=True,
        )
        course = self._course
        plot = course.plot if course is not None else None
        if plot is None:
            return
        scene = plot.scene
        if scene is not None and scene.shapes:
            strips = [np.array([*s.outline, s.outline[0]]) for s in scene.shapes]
            stream.log(
                "map/landmarks",
                rr.LineStrips2D(
                    strips, colors=[_rgb(s.rgba) for s in scene.shapes],
                    labels=[s.name for s in scene.shapes], radii=0.02,
                ),
                static=True,
            )  # fmt: skip
        if scene is not None and scene.sites:
            stream.log(
                "map/sites",
                rr.Points2D(
                    [(s.x, s.y) for s in scene.sites], labels=[s.name for s in scene.sites],
                    colors=[_rgb(s.rgba) for s in scene.sites], radii=0.1, show_labels=True,
                ),
                static=True,
            )  # fmt: skip
        if plot.path:
            stream.log(
                "map/expected_path",
                rr.LineStrips2D([np.array(plot.path)], colors=[[128, 128, 128]], radii=0.01),
                static=True,
            )

    def _blueprint(self, system: CompiledSystem) -> Any:
        """The map and the cameras, the graph, a time series view per component."""
        from fmionnx.core.signals import is_image

        top: list[Any] = [rrb.Spatial2DView(origin="map", name="course")]
        for component in system.components:
            for port in component.interface.ports:
                if is_image(port) and port.name in _cameras(system, component.name):
                    top.append(rrb.Spatial2DView(origin=f"{component.name}/{port.name}"))
        top.append(rrb.GraphView(origin="graph", name="dataflow"))
        series = [
            rrb.TimeSeriesView(origin=rr.escape_entity_path_part(c.name), name=c.name)
            for c in system.components
        ]
        return rrb.Blueprint(
            rrb.Vertical(rrb.Horizontal(*top), rrb.Grid(*series)), collapse_panels=True
        )


def _cameras(system: CompiledSystem, component: str) -> set[str]:
    """The image outputs of ``component`` that feed a connection (those that are rendered)."""
    return {c.src.port for c in system.connections if c.src.component == component}
