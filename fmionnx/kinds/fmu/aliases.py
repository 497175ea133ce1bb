"""Which of the input ports that share value references an FMU runner sets.

An FMI 3 ``<Alias>`` is a port of its own (:mod:`.ports`) that names the same value reference
as its variable. Setting every input port each step would let an alias nobody drives write
its start value over the value a connection or parameter gave the variable (or the other way
round). So among input ports with the same value references, only the given ones are set —
driven by a connection, or given a parameter value — and, when none is, only the first (the
variable itself, which the description lists before its aliases). A port left out has no
run-time buffer, like a string input: it is not recorded (record the port that is set).
"""

from __future__ import annotations

from collections.abc import Sequence

from fmionnx.core.errors import RunError
from fmionnx.core.types import Port


def settable_inputs(
    ports: Sequence[Port], given: frozenset[str]
) -> tuple[list[Port], dict[str, str]]:
    """The ports to set, in order, and each left-out port with the set port it yields to.

    Raises RunError when two given ports share value references (a variable and its alias
    both driven or given): one value would silently overwrite the other.
    """
    by_vrs: dict[tuple[int, ...], list[Port]] = {}
    for port in ports:
        by_vrs.setdefault(port.vrs, []).append(port)
    kept: list[Port] = []
    stand_in: dict[str, str] = {}
    for port in ports:
        sharing = by_vrs[port.vrs]
        chosen = [p for p in sharing if p.name in given] or sharing[:1]
        if len(chosen) > 1 and port is chosen[0]:
            names = " and ".join(f"`{p.name}`" for p in chosen)
            msg = (
                f"{names} name the same FMU variable (an FMI 3 alias) and both are given a "
                "value by a connection or parameter: give it one"
            )
            raise RunError(msg)
        if port in chosen:
            kept.append(port)
        else:
            stand_in[port.name] = chosen[0].name
    return kept, stand_in
