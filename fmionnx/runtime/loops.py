"""Iterated algebraic loops: the loop's whole step repeated until its tear values converge.

Semantics (``docs/execution.md``): at a communication point ``t`` where the loop is due, its
members' states are saved; the *tear inputs* (members' inputs fed by a member stepped later)
start from the producers' published values, which makes the first try exactly the pass the
Gauss-Seidel order would make. One try (a *sweep*) steps the members in order from ``t``,
each reading its inputs as usual, the tear inputs holding the iterate ``x``; afterwards the
tear connections give ``G(x)``. The loop has converged when every tear value satisfies
``|G(x) - x| <= tolerance * (1 + |x|)``: the sweep made with ``x`` is kept (states, outputs,
inputs as used) and recorded. Otherwise the members go back to their saved states and ``x``
is updated: fixed point ``x + relaxation * (G(x) - x)``; Newton ``x - relaxation * J^-1 F(x)``
with ``F(x) = G(x) - x`` and a forward-difference Jacobian (one sweep per tear value). More
than ``max_iterations`` updates, or a singular Jacobian, is a fault naming the loop.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from fmionnx.compile.ir import AlgebraicLoop, CompiledSystem
from fmionnx.core.errors import ModelTerminated, RunError
from fmionnx.core.runner import Buffer, Runner, StateSaving
from fmionnx.runtime.stepping import Work
from fmionnx.runtime.transfer import (
    NonFiniteWatch,
    Transfer,
    connection_views,
    make_transfer,
)

Vector = npt.NDArray[np.float64]


def _fd_step(view: Buffer) -> float:
    """Square root of the machine epsilon of ``view``'s float type (float32, else float64)."""
    eps = np.finfo(np.float32).eps if view.dtype == np.float32 else np.finfo(np.float64).eps
    return math.sqrt(float(eps))


@dataclass(frozen=True)
class LoopMember:
    """One member of the loop: its runner (whose state a sweep goes back to) and its work
    (:class:`~fmionnx.runtime.stepping.Work`: its transfers but the tears', its step, its
    tracks)."""

    runner: StateSaving
    work: Work


class IteratedLoop:
    """Steps one algebraic loop per communication point by iteration (see module docs)."""

    def __init__(
        self,
        loop: AlgebraicLoop,
        members: Sequence[LoopMember],
        tears: Sequence[Transfer],
        views: Sequence[Buffer],
    ) -> None:
        self.loop = loop
        self.members = tuple(members)
        self._tears = tuple(tears)
        self._views = tuple(views)
        self._slices: list[tuple[int, int]] = []
        offset = 0
        for view in self._views:
            self._slices.append((offset, offset + view.size))
            offset += view.size
        self._size = offset
        #: Relative finite-difference step per tear value: the square root of the precision
        #: of the input it is written to (a float32 input would swallow a float64-sized step).
        steps = [np.full(view.size, _fd_step(view)) for view in self._views]
        self._fd_steps: Vector = np.concatenate(steps) if steps else np.zeros(0)
        #: Updates made at the last communication point, and the most at any point so far.
        self.iterations = 0
        self.peak_iterations = 0
        self.label = "+".join(loop.members)

    # -- the tear values ---------------------------------------------------------------------

    def _gather(self) -> Vector:
        x = np.empty(self._size, dtype=np.float64)
        for view, (a, b) in zip(self._views, self._slices, strict=True):
            x[a:b] = view
        return x

    def _scatter(self, x: Vector) -> None:
        """Write ``x`` into the tear inputs, and round ``x`` to what they hold (float32 ...),
        so that the residual compares the values really used."""
        for view, (a, b) in zip(self._views, self._slices, strict=True):
            np.copyto(view, x[a:b], casting="unsafe")
            x[a:b] = view

    def _evaluate(self, t: float, h: float, x: Vector, first: bool) -> Vector:
        """One sweep from the saved state with tear inputs ``x``; returns ``G(x)``."""
        if not first:
            for member in self.members:
                member.runner.restore_state(t)
        self._scatter(x)
        for i, member in enumerate(self.members):
            member.work.feed(t)
            try:
                member.work.step(t, h)
            except ModelTerminated:
                self._scatter(x)
                self._sample(self.members[: i + 1])
                raise
        for tear in self._tears:
            tear(t)
        return self._gather()

    # -- one communication point -------------------------------------------------------------

    def step(self, t: float, h: float) -> None:
        """Solve the loop at ``t`` and leave its members stepped to ``t + h``."""
        for member in self.members:
            member.runner.save_state(t)
        for tear in self._tears:  # the published values: the first try is the plain pass
            tear(t)
        x = self._gather()
        newton = self.loop.solver.method == "newton"
        x = self._newton(t, h, x) if newton else self._fixed_point(t, h, x)
        self._scatter(x)  # the inputs the kept sweep used
        self._sample(self.members)

    def _fixed_point(self, t: float, h: float, x: Vector) -> Vector:
        solver = self.loop.solver
        g = self._evaluate(t, h, x, first=True)
        updates = 0
        while not self._converged(g - x, x):
            if updates == solver.max_iterations:
                raise self._not_converged(t, updates, g - x, x)
            with np.errstate(all="ignore"):
                x = x + solver.relaxation * (g - x)
            updates += 1
            g = self._evaluate(t, h, x, first=False)
        self._count(updates)
        return x

    def _newton(self, t: float, h: float, x: Vector) -> Vector:
        solver = self.loop.solver
        f = self._evaluate(t, h, x, first=True) - x
        updates = 0
        while not self._converged(f, x):
            if updates == solver.max_iterations:
                raise self._not_converged(t, updates, f, x)
            jacobian = self._jacobian(t, h, x, f)
            try:
                dx = np.linalg.solve(jacobian, -f)
            except np.linalg.LinAlgError:
                raise self._fault(
                    t,
                    f"the Jacobian of its tear values is singular after {updates} iteration"
                    f"{'' if updates == 1 else 's'} (newton); try `solver: fixed-point`",
                ) from None
            with np.errstate(all="ignore"):
                x = x + solver.relaxation * dx
            updates += 1
            f = self._evaluate(t, h, x, first=False) - x
        self._count(updates)
        return x

    def _jacobian(self, t: float, h: float, x: Vector, f: Vector) -> Vector:
        """Forward differences of ``F(x) = G(x) - x``, one sweep per tear value."""
        jacobian = np.empty((x.size, x.size), dtype=np.float64)
        for j in range(x.size):
            shifted = x.copy()
            shifted[j] += self._fd_steps[j] * max(1.0, abs(float(x[j])))
            g = self._evaluate(t, h, shifted, first=False)  # rounds ``shifted`` to the input
            jacobian[:, j] = (g - shifted - f) / (shifted[j] - x[j])
        if not np.isfinite(jacobian).all():
            raise self._fault(t, "its finite-difference Jacobian is not finite (newton)")
        return jacobian

    def _count(self, updates: int) -> None:
        self.iterations = updates
        self.peak_iterations = max(self.peak_iterations, updates)

    # -- convergence and faults --------------------------------------------------------------

    def _converged(self, residual: Vector, x: Vector) -> bool:
        return self._scaled(residual, x) <= self.loop.solver.tolerance

    @staticmethod
    def _scaled(residual: Vector, x: Vector) -> float:
        """``max |r_i| / (1 + |x_i|)``; NaN when a value is not finite (never converged)."""
        with np.errstate(all="ignore"):
            scaled = np.abs(residual) / (1.0 + np.abs(x))
        if not np.isfinite(scaled).all():
            return math.nan
        return float(scaled.max()) if scaled.size else 0.0

    def _not_converged(self, t: float, updates: int, residual: Vector, x: Vector) -> RunError:
        solver = self.loop.solver
        scaled = self._scaled(residual, x)
        tears = ", ".join(str(ref) for ref in self.loop.tears)
        return self._fault(
            t,
            f"did not converge in {updates} iteration{'' if updates == 1 else 's'} "
            f"({solver.method}, relaxation {solver.relaxation:g}): the residual "
            f"max |G(x) - x| / (1 + |x|) is {scaled:.3g}, the tolerance {solver.tolerance:g} "
            f"(tear variables: {tears}); raise `max_iterations`, lower `relaxation`, or try "
            "the other solver",
        )

    def _fault(self, t: float, message: str) -> RunError:
        members = ", ".join(f"`{m}`" for m in self.loop.members)
        return RunError(
            f"algebraic loop {self.loop.label} (components {members}) at t={t:.6g} s: {message}",
            component=self.label,
            time=t,
        )

    @staticmethod
    def _sample(members: Sequence[LoopMember]) -> None:
        """Record the kept sweep: the inputs it used and the outputs it produced."""
        for member in members:
            member.work.record_inputs()
            member.work.record_outputs()


def iterated_loop(
    system: CompiledSystem,
    loop: AlgebraicLoop,
    runners: dict[str, Runner],
    work: dict[str, Work],
    watch: NonFiniteWatch | None = None,
) -> IteratedLoop:
    """Prepare ``loop``: ``work`` holds each member's work as the master made it (transfers
    one per incoming connection, in :meth:`CompiledSystem.inputs_of` order); ``watch``: the
    run's ``--on-nonfinite warn`` record (None: a non-finite tear value is a fault)."""
    tears = set(loop.tears)
    members = []
    tear_transfers: list[Transfer] = []
    views: list[Buffer] = []
    for name in loop.members:
        runner = runners[name]
        if not isinstance(runner, StateSaving):
            msg = (
                f"component `{name}` is part of the algebraic loop {loop.label}, but its runner "
                "cannot save and restore its state"
            )
            raise RunError(msg, component=name)
        own = work[name]
        kept = []
        for transfer, connection in zip(own.transfers, system.inputs_of(name), strict=True):
            if connection.dst in tears:
                source = runners[connection.src.component]
                tear_transfers.append(make_transfer(connection, source, runner, watch=watch))
                views.append(connection_views(connection, source, runner)[1])
            else:
                kept.append(transfer)
        members.append(LoopMember(runner, dataclasses.replace(own, transfers=tuple(kept))))
    return IteratedLoop(loop, members, tear_transfers, views)
