"""The runner of a ``signal`` component: writes each output's value at the time reached."""

from __future__ import annotations

import bisect
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from fmionnx.core.errors import ModelError, RunError
from fmionnx.core.runner import Buffer, OutputCopies
from fmionnx.core.types import Component
from fmionnx.kinds.signal.table import read_table
from fmionnx.kinds.signal.waveforms import SignalConfig

#: A breakpoint closer than this fraction of a step to ``t + h`` counts as reached at ``t + h``.
#: Communication points are a whole step apart, so this only absorbs rounding (``t + h`` for
#: ``0.1 * 19 + 0.1`` is not ``0.1 * 20``), never moves an edge to another point.
SNAP = 1e-6


def snap(t: float, points: Sequence[float], tolerance: float) -> float:
    """``t``, or the first of the sorted ``points`` within ``tolerance`` of it."""
    if tolerance <= 0.0 or not points:
        return t
    i = bisect.bisect_left(points, t - tolerance)
    if i < len(points) and points[i] <= t + tolerance:
        return points[i]
    return t


class SignalRunner:
    """Writes each output's value at the communication point a step reaches."""

    def __init__(self, component: Component) -> None:
        self.component = component
        self.lazy_outputs: frozenset[str] = frozenset()
        config = component.config
        assert isinstance(config, SignalConfig)
        self._config = config
        self._waves = [
            (np.zeros(1), wave, tuple(sorted(wave.breakpoints))) for _, wave in config.outputs
        ]
        self._outputs: dict[str, Buffer] = {
            name: buffer
            for (name, _), (buffer, _, _) in zip(config.outputs, self._waves, strict=True)
        }
        self._times: tuple[float, ...] = ()
        self._rows: npt.NDArray[np.float64] | None = None
        self._current: npt.NDArray[np.float64] = np.zeros(0)
        self._saved: OutputCopies | None = None

    def instantiate(self) -> None:
        """Read the table (a RunError when it no longer reads, or no longer fits the ports)."""
        if self._config.interpolation is None:
            return
        name = self.component.name
        try:
            table = read_table(self.component.path)
        except ModelError as exc:
            raise RunError(f"component `{name}`: {exc}", component=name) from None
        ports = tuple(p.name for p in self.component.interface.ports)
        if table.names != ports:
            table_file = self.component.path.name
            msg = f"component `{name}`: the columns of `{table_file}` changed since it was checked"
            raise RunError(msg, component=name)
        self._times = table.times
        self._rows = np.array(table.rows, dtype=np.float64)
        current = self._rows[0].copy()
        self._outputs = {port: current[i : i + 1] for i, port in enumerate(ports)}
        self._current = current

    def setup(self, start: float, stop: float) -> None:
        """Outputs hold their values at ``start``."""
        self._write(start, 0.0)

    def input_buffer(self, port: str) -> Buffer:
        """A signal has no inputs."""
        raise KeyError(port)

    def output_buffer(self, port: str) -> Buffer:
        """The one-element buffer of output ``port``."""
        return self._outputs[port]

    def step(self, t: float, h: float) -> None:
        """Outputs take their values at ``t + h``."""
        self._write(t + h, SNAP * h)

    def _write(self, t: float, tolerance: float) -> None:
        for buffer, wave, points in self._waves:
            buffer[0] = wave.at(snap(t, points, tolerance))
        if self._rows is not None:
            self._write_table(snap(t, self._times, tolerance))

    def _write_table(self, t: float) -> None:
        times, rows = self._times, self._rows
        assert rows is not None
        i = bisect.bisect_right(times, t) - 1
        if i < 0:
            self._current[:] = rows[0]
        elif i >= len(times) - 1 or self._config.interpolation == "hold":
            self._current[:] = rows[i]
        else:
            fraction = (t - times[i]) / (times[i + 1] - times[i])
            self._current[:] = rows[i] + (rows[i + 1] - rows[i]) * fraction

    def save_state(self, t: float) -> None:
        """Values come from the time alone: keep the outputs only (a signal has no inputs,
        so it is never part of an algebraic loop; this keeps the kind's promise anyway)."""
        self._saved = OutputCopies(list(self._outputs.values()))
        self._saved.save()

    def restore_state(self, t: float) -> None:
        """Back to the outputs of :meth:`save_state`."""
        if self._saved is not None:
            self._saved.restore()

    def produce(self, port: str) -> None:
        """Nothing is lazy."""

    def terminate(self) -> None:
        """Nothing to free."""
