"""Symbolic ONNX dimensions: what the element counts fed to a model's inputs fix.

It lives here, on ports and counts only, because the compiler (which reaches no kind's own
modules) and the ONNX runner must come to the same numbers: the compiler to refuse a
connection that cannot fit, the runner to shape its tensors.

A ``dim_param`` (``batch``) is one number wherever the graph names it: ``x: [batch, 3]`` fed
six elements makes ``batch`` 2, so ``y: [batch, 3]`` gives six too. The rule:

* an input fed ``n`` elements fixes its one unknown dimension to ``n`` divided by the rest
  (a name repeated, ``[n, n]``, by the whole root); a name fixed by one input is known in
  every other port that names it, so inputs are solved until none fixes more;
* an input left with two or more unknown dimensions is **ambiguous** (``[a, b, 3]`` fed six
  elements could be ``[2,1,3]`` or ``[1,2,3]``): nothing is guessed, it is an error;
* a name only undriven inputs use is 1 (the runner's buffer for an unconnected input);
* an unnamed dimension (``?``) belongs to its own port: an input's is fixed by its own count,
  an output's, like a name no input uses, is known only from the run's first output.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from fmionnx.core.types import Causality, Port

#: How the interface reader writes a dimension without a value or a name.
UNNAMED = "?"


@dataclass(frozen=True, slots=True)
class DimProblem:
    """Why the count fed to input ``port`` cannot fill its shape."""

    port: str
    message: str


@dataclass(frozen=True, slots=True)
class Dims:
    """The names fixed by the inputs' counts, and what could not be fixed."""

    bound: Mapping[str, int]
    problems: tuple[DimProblem, ...] = ()


def _unknown(shape: Iterable[int | str], bound: Mapping[str, int]) -> list[str]:
    return [d for d in shape if isinstance(d, str) and (d == UNNAMED or d not in bound)]


def _known_product(shape: Iterable[int | str], bound: Mapping[str, int]) -> int:
    return math.prod(
        d if isinstance(d, int) else bound[d] for d in shape if isinstance(d, int) or d in bound
    )


def _root(value: int, power: int) -> int | None:
    """The whole number whose ``power``-th power is ``value``; None when there is none."""
    guess = round(value ** (1 / power))
    return next((r for r in (guess - 1, guess, guess + 1) if r > 0 and r**power == value), None)


def _solve(port: Port, size: int, bound: dict[str, int]) -> DimProblem | bool | None:
    """Fix what ``size`` elements fed to ``port`` fix in ``bound``: a problem, True when it
    fixed what it could (nothing left to learn from it), False when it must wait."""
    unknown = _unknown(port.shape, bound)
    known = _known_product(port.shape, bound)
    shape = port.shape_text()
    if not unknown:
        if known != size:
            named = ", ".join(f"{d} = {bound[d]}" for d in port.shape if isinstance(d, str))
            why = f"{shape}: it has {known} with {named}, fixed by another input"
            return DimProblem(port.name, f"{size} elements cannot fill {why}")
        return True
    if len(set(unknown)) > 1 or (UNNAMED in unknown and len(unknown) > 1):
        return False
    if known == 0:  # a zero dimension beside it: nothing to learn, any size is empty
        if size:
            return DimProblem(port.name, f"{size} elements cannot fill {shape}: it is empty")
        return True
    if size % known:
        return DimProblem(
            port.name, f"{size} elements cannot fill {shape}: {known} do not divide it"
        )
    value = _root(size // known, len(unknown))
    if value is None:
        msg = f"{size} elements cannot fill {shape}: `{unknown[0]}` has no whole size"
        return DimProblem(port.name, msg)
    if unknown[0] != UNNAMED:
        bound[unknown[0]] = value
    return True


def bind_dims(ports: Iterable[Port], sizes: Mapping[str, int]) -> Dims:
    """The dimension names fixed by ``sizes`` (element counts fed to input ports, by name)
    among ``ports`` (one model's), by the rule of the module's docstring."""
    ports = list(ports)
    inputs = [p for p in ports if p.causality is Causality.INPUT]
    bound: dict[str, int] = {}
    problems: list[DimProblem] = []
    pending = [(p, sizes[p.name]) for p in inputs if p.name in sizes and p.size is None]
    fixed_any = True
    while pending and fixed_any:
        fixed_any = False
        waiting = []
        for port, size in pending:
            done = _solve(port, size, bound)
            if done is False:
                waiting.append((port, size))
            elif isinstance(done, DimProblem):
                problems.append(done)
            else:
                fixed_any = True
        pending = waiting
    for port, size in pending:
        names = ", ".join(f"`{d}`" for d in dict.fromkeys(_unknown(port.shape, bound)))
        msg = (
            f"{size} elements fed to shape {port.shape_text()} leave {names} unknown: "
            "the shape is ambiguous"
        )
        problems.append(DimProblem(port.name, msg))
    for port in inputs:  # what undriven (or ambiguous) inputs name is 1, as their buffers are
        for dim in port.shape:
            if isinstance(dim, str) and dim != UNNAMED:
                bound.setdefault(dim, 1)
    return Dims(bound, tuple(problems))


def resolved_shape(port: Port, dims: Dims, size: int | None = None) -> tuple[int | None, ...]:
    """``port``'s shape with the names ``dims`` fixed; an input's one remaining unknown
    dimension filled from ``size`` (the count fed to it) when that divides, other unknowns
    (an output's dimension no input names) None."""
    shape: list[int | None] = [
        d if isinstance(d, int) else dims.bound.get(d) if d != UNNAMED else None for d in port.shape
    ]
    open_ = [i for i, d in enumerate(shape) if d is None]
    if port.causality is Causality.INPUT:
        known = math.prod(d for d in shape if d is not None)
        if size is not None and len(open_) == 1 and known and size % known == 0:
            shape[open_[0]] = size // known
        else:
            shape = [1 if d is None else d for d in shape]
    return tuple(shape)


def known_count(shape: tuple[int | None, ...]) -> int | None:
    """The element count of a resolved shape; None while a dimension is unknown."""
    if any(d is None for d in shape):
        return None
    return math.prod(d for d in shape if d is not None)
