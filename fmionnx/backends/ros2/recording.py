"""Results of a ROS 2 run: each node records its own component, the supervisor merges.

A node records exactly what the in-process master records for its component (the same
:class:`~fmionnx.runtime.recorder.Track` objects: recorded inputs sampled before a
step, outputs after it, one row per own step, the first output row after set-up) and saves the
rows to ``<record dir>/<component>.npz`` with a ``<component>.json`` status when it ends. The
supervisor rebuilds a :class:`~fmionnx.runtime.recorder.Recorder` from those files,
so the base-step expansion, the column order and therefore ``results.csv`` are the in-process
ones, bit for bit, when the values are.
"""

from __future__ import annotations

import io
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.errors import RunError
from fmionnx.core.runner import Buffer, Runner
from fmionnx.core.safewrite import write_bytes_atomic, write_text_atomic
from fmionnx.core.signals import column_names, is_image
from fmionnx.core.types import Causality, PortRef, flat_index
from fmionnx.runtime.master import default_record, required_refs
from fmionnx.runtime.recorder import Recorder, Track
from fmionnx.runtime.result import RunOptions


def record_refs(system: CompiledSystem, options: RunOptions | None = None) -> tuple[PortRef, ...]:
    """The signals a run records: as :attr:`Master.record_refs` decides them."""
    if options is not None and options.record is not None:
        return options.record
    chosen = system.record or default_record(system)
    return (*chosen, *required_refs(system))


@dataclass
class NodeRecording:
    """The tracks of one component: inputs before a step, outputs after it."""

    component: str
    before: Track | None
    after: Track | None

    @property
    def tracks(self) -> tuple[Track, ...]:
        """The tracks that exist."""
        return tuple(t for t in (self.before, self.after) if t is not None)


def node_recording(
    system: CompiledSystem, runner: Runner, refs: tuple[PortRef, ...]
) -> NodeRecording:
    """Tracks for ``runner``'s component (call after set-up: samples the initial outputs)."""
    name = runner.component.name
    period = runner.component.period_steps
    total = system.run.steps
    seen: set[str] = set()
    sides: tuple[list[tuple[list[str], Buffer]], list[tuple[list[str], Buffer]]] = ([], [])
    for ref in refs:
        if ref.component != name:
            continue
        port = runner.component.port(ref.port)
        if is_image(port) or port.name in runner.lazy_outputs:
            continue
        names = column_names(name, port, ref.index)
        if any(n in seen for n in names):
            continue
        is_output = port.causality is Causality.OUTPUT
        try:
            buffer = (
                runner.output_buffer(port.name) if is_output else runner.input_buffer(port.name)
            )
        except KeyError:
            continue
        seen.update(names)
        if ref.index is not None:
            i = flat_index(port, ref.index)
            buffer = buffer[i : i + 1]
        sides[1 if is_output else 0].append((names, buffer))
    tracks: list[Track | None] = []
    for items in sides:
        if not items:
            tracks.append(None)
            continue
        track = Track(period, total // period + 2)
        for names, buffer in items:
            track.add(names, buffer)
        track.allocate()
        tracks.append(track)
    before, after = tracks
    if after is not None:
        after.sample()
    return NodeRecording(name, before, after)


def save_node(
    folder: Path,
    recording: NodeRecording | None,
    component: str,
    *,
    status: str,
    steps: int,
    error: RunError | None = None,
    inputs: dict[str, dict[str, str | int]] | None = None,
    ended: dict[str, str | float | int] | None = None,
    statistics: Mapping[str, object] | None = None,
    warnings: list[str] | None = None,
) -> None:
    """Write ``<component>.npz`` (rows) and ``<component>.json`` (how the node ended and,
    in a free run, what happened to each input: ``inputs``, see :mod:`.inputsync`; when its
    model ended the simulation, ``ended_by``: component, time, reason and step)."""
    folder.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, Any] = {}
    after = recording.after if recording else None
    for i, track in enumerate(recording.tracks if recording else ()):
        arrays[f"rows{i}"] = track.rows[: track.count]
        arrays[f"columns{i}"] = np.array(track.columns, dtype=str)
        arrays[f"period{i}"] = np.array(track.period_steps)
        arrays[f"after{i}"] = np.array(track is after)
    packed = io.BytesIO()
    np.savez(packed, **arrays)
    write_bytes_atomic(folder / f"{component}.npz", packed.getvalue())
    info = {
        "component": component,
        "status": status,
        "steps": steps,
        "error": None
        if error is None
        else {
            "message": str(error),
            "component": error.component,
            "port": error.port,
            "time": error.time,
        },
    }
    if inputs is not None:
        info["inputs"] = inputs
    if ended is not None:
        info["ended_by"] = ended
    if statistics is not None:
        info["statistics"] = statistics
    if warnings:
        info["warnings"] = warnings
    write_text_atomic(folder / f"{component}.json", json.dumps(info, indent=2))


def load_status(folder: Path, component: str) -> dict[str, Any] | None:
    """The status a node wrote, or None (it never got that far)."""
    path = folder / f"{component}.json"
    try:
        loaded: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return loaded


def error_of(status: dict[str, Any]) -> RunError | None:
    """The fault a node reported in its status."""
    error = status.get("error")
    if not isinstance(error, dict):
        return None
    return RunError(
        str(error.get("message")),
        component=error.get("component"),
        port=error.get("port"),
        time=error.get("time"),
    )


def merge(
    folder: Path,
    components: list[str],
    refs: tuple[PortRef, ...],
    system: CompiledSystem,
    issued: Mapping[str, int] | None = None,
) -> Recorder:
    """A recorder holding every node's saved tracks, columns in the in-process order.

    ``issued``: per component, the steps the in-process order issued before the run ended
    (a model ending it, :func:`issued_before`); rows of later steps a node did anyway, running
    concurrently, are dropped (inputs: one row per step, outputs: one more, the initial one).
    """
    recorder = Recorder()
    available: set[str] = set()
    for component in components:
        path = folder / f"{component}.npz"
        if not path.exists():
            continue
        with np.load(path, allow_pickle=False) as data:
            i = 0
            while f"rows{i}" in data:
                rows = np.asarray(data[f"rows{i}"], dtype=np.float64)
                columns = [str(c) for c in data[f"columns{i}"]]
                count = len(rows)
                if issued is not None and component in issued:
                    after = f"after{i}" in data and bool(data[f"after{i}"])
                    count = min(count, issued[component] + (1 if after else 0))
                    rows = rows[:count]
                track = Track(int(data[f"period{i}"]), count, columns, [], rows, count)
                if len(rows):
                    recorder.tracks.append(track)
                    available.update(columns)
                i += 1
    seen: set[str] = set()
    for ref in refs:
        port = system.component(ref.component).port(ref.port)
        names = column_names(ref.component, port, ref.index)
        if any(n in seen for n in names) or not all(n in available for n in names):
            continue
        seen.update(names)
        recorder.order.extend(names)
    return recorder


def issued_before(
    system: CompiledSystem, n: int, ender: str, components: list[str]
) -> dict[str, int]:
    """Per component but ``ender``: the steps the in-process order issues before ``ender``'s
    step from base step ``n`` (the one that ended the run).

    In-process, components before ``ender`` in the order step at ``n``, those after it do not
    (``Master._allowed``); ROS 2 nodes step concurrently, so the supervisor trims to this.
    """
    place = system.order.index(ender)
    counts = {}
    for component in components:
        if component == ender:
            continue
        period = system.component(component).period_steps
        before = -(-n // period)
        if n % period == 0 and system.order.index(component) < place:
            before += 1
        counts[component] = before
    return counts
