"""The channels a run is shown on: one description for the MCAP recording and Foxglove live.

``--record run.mcap`` (:mod:`.mcap_record`) and ``--view foxglove`` (:mod:`fmionnx.pipeline.views`)
publish the same topics, with the same schemas and the same bytes, made here:

========================  ====================================  ================================
topic                     schema (encoding)                     holds
========================  ====================================  ================================
``/<component>/<port>``   ``sensor_msgs/msg/Image`` (ros2msg,   each camera frame as rendered
                          CDR)                                  (``rgb8``)
``/signals``              ``fmionnx.Signals`` (JSON)            ``time`` and every recorded
                                                                results column, at most
                                                                :data:`MAX_SIGNAL_RATE` per
                                                                simulated second
``/map``                  ``foxglove.SceneUpdate`` (JSON)       the course of the first xy plot:
                                                                its scene's shapes and sites,
                                                                the expected path
``/trajectory``           ``foxglove.PosesInFrame`` (JSON)      that plot's path so far, at most
                                                                :data:`TRAJECTORY_RATE` points
                                                                per simulated second
``/graph``                ``fmionnx.Graph`` (JSON)              the dataflow graph: components
                                                                and connections
``/checks``               ``fmionnx.Checks`` (JSON)             each check's verdict, at the end
========================  ====================================  ================================

Foxglove's Image panel shows the frames, its Plot panel the signals (message path
``/signals.odometry\\.posX``), its 3D panel the map and the trajectory (frame ``map``), its
Raw Messages panel the graph and the checks. docs/viewing.md lists them too.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from fmionnx.compile.ir import CompiledSystem, Plot
    from fmionnx.core.types import PortRef
    from fmionnx.runtime.checks import CheckOutcome

#: Signals are thinned to at most this many rows per simulated second.
MAX_SIGNAL_RATE = 100.0
#: A trajectory keeps at most this many points per simulated second.
TRAJECTORY_RATE = 10.0
IMAGE_TYPE = "sensor_msgs/msg/Image"
SIGNALS = "/signals"
MAP = "/map"
TRAJECTORY = "/trajectory"
GRAPH = "/graph"
CHECKS = "/checks"
#: The frame the map and the trajectory are drawn in (Foxglove's 3D panel follows it).
MAP_FRAME = "map"


@dataclass(frozen=True)
class ChannelSpec:
    """One channel: topic, schema (name, encoding, text) and how its messages are encoded."""

    topic: str
    schema_name: str
    schema_encoding: str
    schema: bytes
    message_encoding: str


def stamp(time: float) -> tuple[int, int, int]:
    """(sec, nanosec, log time in ns) of a simulated time (negative times clamp to 0)."""
    ns = max(0, round(time * 1e9))
    return ns // 1_000_000_000, ns % 1_000_000_000, ns


def signal_stride(step: float) -> int:
    """Base steps between two signal rows (at most :data:`MAX_SIGNAL_RATE` a second)."""
    return max(1, math.ceil(1.0 / (MAX_SIGNAL_RATE * step) - 1e-9))


def trajectory_stride(step: float) -> int:
    """Base steps between two trajectory points (at most :data:`TRAJECTORY_RATE` a second)."""
    return max(1, math.ceil(1.0 / (TRAJECTORY_RATE * step) - 1e-9))


def image_topic(component: str, port: str) -> str:
    """The topic of a camera's frames."""
    return f"/{component}/{port}"


class ImageCodec:
    """Camera frames as ROS 2 ``sensor_msgs/msg/Image`` in CDR (rosbags' Humble type store),
    what ROS 2 tools and Foxglove decode alike."""

    def __init__(self) -> None:
        from rosbags.typesys import Stores, get_typestore

        self._store: Any = get_typestore(Stores.ROS2_HUMBLE)
        text, _ = self._store.generate_msgdef(IMAGE_TYPE, ros_version=2)
        self._schema = str(text).encode()

    def channel(self, component: str, port: str) -> ChannelSpec:
        """The channel of ``component.port``'s frames."""
        return ChannelSpec(image_topic(component, port), IMAGE_TYPE, "ros2msg", self._schema, "cdr")

    def encode(self, component: str, port: str, time: float, image: npt.NDArray[Any]) -> bytes:
        """One RGB frame (``uint8[H,W,3]``) as a CDR Image message stamped ``time``."""
        sec, nanosec, _ = stamp(time)
        height, width = int(image.shape[0]), int(image.shape[1])
        types = self._store.types
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
        return bytes(self._store.serialize_cdr(message, IMAGE_TYPE))


def _json_channel(topic: str, name: str, schema: Mapping[str, object]) -> ChannelSpec:
    text = json.dumps({"title": name, **schema}).encode()
    return ChannelSpec(topic, name, "jsonschema", text, "json")


def _encode(payload: object) -> bytes:
    return json.dumps(payload, allow_nan=False).encode()


def _finite(value: float) -> float | None:
    """JSON has no NaN/Inf; they become null."""
    return value if math.isfinite(value) else None


def signals_channel(columns: Sequence[str]) -> ChannelSpec:
    """``/signals``: ``time`` and one number per results column."""
    properties = {"time": {"type": "number"}, **{n: {"type": ["number", "null"]} for n in columns}}
    return _json_channel(SIGNALS, "fmionnx.Signals", {"type": "object", "properties": properties})


def encode_signals(time: float, values: Mapping[str, float]) -> bytes:
    """One ``/signals`` message."""
    payload: dict[str, float | None] = {"time": time}
    payload.update({name: _finite(float(v)) for name, v in values.items()})
    return _encode(payload)


def _time(time: float) -> dict[str, int]:
    sec, nanosec, _ = stamp(time)
    return {"sec": sec, "nsec": nanosec}


def _point(x: float, y: float, z: float = 0.0) -> dict[str, float]:
    return {"x": x, "y": y, "z": z}


_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
_ORIGIN = {"position": _point(0.0, 0.0), "orientation": _IDENTITY}


def _colour(rgba: Sequence[float], alpha: float | None = None) -> dict[str, float]:
    red, green, blue, a = rgba
    return {"r": red, "g": green, "b": blue, "a": max(a, 0.5) if alpha is None else alpha}


def map_plot(system: CompiledSystem) -> Plot | None:
    """The plot the views draw the robot's course from: the first xy plot (over its map)."""
    for plot in system.plots:
        if plot.xy is not None and len(plot.series) == 2:
            return plot
    return None


def map_channel() -> ChannelSpec:
    """``/map``: the course as Foxglove scene entities."""
    return _json_channel(
        MAP, "foxglove.SceneUpdate",
        {"type": "object", "properties": {"deletions": {"type": "array"}, "entities": {"type": "array"}}},
    )  # fmt: skip


def encode_map(time: float, plot: Plot) -> bytes:
    """The course of ``plot``: its scene's shapes (outlines), sites (spheres and names) and
    the expected path, as one ``foxglove.SceneUpdate`` entity in the ``map`` frame."""
    lines: list[dict[str, object]] = []
    spheres: list[dict[str, object]] = []
    texts: list[dict[str, object]] = []
    scene = plot.scene
    if scene is not None:
        for shape in scene.shapes:
            lines.append(_line(1, [_point(x, y) for x, y in shape.outline], _colour(shape.rgba)))
        for site in scene.sites:
            where = {"position": _point(site.x, site.y), "orientation": _IDENTITY}
            size = {"x": 0.15, "y": 0.15, "z": 0.15}
            spheres.append({"pose": where, "size": size, "color": _colour(site.rgba)})
            texts.append(
                {"pose": where, "billboard": True, "font_size": 14.0, "scale_invariant": True,
                 "color": _colour((0.0, 0.0, 0.0, 1.0)), "text": site.name}
            )  # fmt: skip
    if plot.path:
        grey = _colour((0.5, 0.5, 0.5, 1.0))
        lines.append(_line(0, [_point(x, y) for x, y in plot.path], grey, dashed=True))
    entity = {
        "timestamp": _time(time), "frame_id": MAP_FRAME, "id": "course",
        "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": True, "metadata": [],
        "arrows": [], "cubes": [], "spheres": spheres, "cylinders": [], "lines": lines,
        "triangles": [], "texts": texts, "models": [],
    }  # fmt: skip
    return _encode({"deletions": [], "entities": [entity]})


def _line(
    kind: int, points: list[dict[str, float]], colour: dict[str, float], *, dashed: bool = False
) -> dict[str, object]:
    """A ``LinePrimitive``: ``kind`` 0 a strip, 1 a loop (an outline)."""
    return {
        "type": kind, "pose": _ORIGIN, "thickness": 0.01 if dashed else 0.02,
        "scale_invariant": False, "points": points, "color": colour, "colors": [],
        "indices": [],
    }  # fmt: skip


def trajectory_channel() -> ChannelSpec:
    """``/trajectory``: the path so far as Foxglove poses."""
    return _json_channel(
        TRAJECTORY, "foxglove.PosesInFrame",
        {"type": "object", "properties": {"timestamp": {"type": "object"},
         "frame_id": {"type": "string"}, "poses": {"type": "array"}}},
    )  # fmt: skip


def encode_trajectory(time: float, xs: Sequence[float], ys: Sequence[float]) -> bytes:
    """The path through ``(xs[i], ys[i])`` (non-finite points left out)."""
    poses = [
        {"position": _point(float(x), float(y)), "orientation": _IDENTITY}
        for x, y in zip(xs, ys, strict=True)
        if math.isfinite(x) and math.isfinite(y)
    ]
    return _encode({"timestamp": _time(time), "frame_id": MAP_FRAME, "poses": poses})


def graph_channel() -> ChannelSpec:
    """``/graph``: components and connections."""
    return _json_channel(
        GRAPH, "fmionnx.Graph",
        {"type": "object", "properties": {"nodes": {"type": "array"}, "edges": {"type": "array"}}},
    )  # fmt: skip


def graph_of(system: CompiledSystem) -> dict[str, list[dict[str, str]]]:
    """The dataflow graph: a node per component (name, kind), an edge per connection
    (producer and consumer components, the connection as written)."""
    nodes = [{"id": c.name, "kind": c.kind} for c in system.components]
    edges = [
        {"from": c.src.component, "to": c.dst.component, "connection": str(c)}
        for c in system.connections
    ]
    return {"nodes": nodes, "edges": edges}


def encode_graph(system: CompiledSystem) -> bytes:
    """One ``/graph`` message."""
    return _encode(graph_of(system))


def checks_channel() -> ChannelSpec:
    """``/checks``: each check's verdict."""
    return _json_channel(
        CHECKS, "fmionnx.Checks",
        {"type": "object", "properties": {"time": {"type": "number"}, "checks": {"type": "array"}}},
    )  # fmt: skip


def encode_checks(time: float, outcomes: Sequence[CheckOutcome]) -> bytes:
    """One ``/checks`` message: run.json's entries for ``outcomes``."""
    return _encode({"time": time, "checks": [outcome.as_json() for outcome in outcomes]})


def cameras(system: CompiledSystem) -> list[tuple[str, str]]:
    """(component, port) of each image output that feeds a connection: the frames a run
    renders."""
    from fmionnx.core.signals import is_image

    found: dict[tuple[str, str], None] = {}
    for connection in system.connections:
        if is_image(connection.src_port):
            found[(connection.src.component, connection.src.port)] = None
    return list(found)


def recorded_columns(system: CompiledSystem, record: Sequence[PortRef] | None = None) -> list[str]:
    """The results columns a run of ``system`` records (``record``: the run's own choice),
    as the master chooses them: images and ports of unknown size left out."""
    from fmionnx.core.signals import column_names, is_image
    from fmionnx.runtime.master import default_record, required_refs

    refs = (
        record
        if record is not None
        else (*(system.record or default_record(system)), *required_refs(system))
    )
    names: dict[str, None] = {}
    for ref in refs:
        port = system.component(ref.component).port(ref.port)
        if is_image(port) or port.size is None:
            continue
        names.update(dict.fromkeys(column_names(ref.component, port, ref.index)))
    return list(names)


def planned(
    system: CompiledSystem, images: ImageCodec, record: Sequence[PortRef] | None = None
) -> list[ChannelSpec]:
    """Every channel a run of ``system`` publishes, known before it starts: a live client
    that connects early is told of them all at once."""
    found = [graph_channel(), signals_channel(recorded_columns(system, record))]
    found += [images.channel(component, port) for component, port in cameras(system)]
    if map_plot(system) is not None:
        found += [map_channel(), trajectory_channel()]
    if system.checks:
        found.append(checks_channel())
    return found
