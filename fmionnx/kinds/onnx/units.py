"""Units for ONNX ports: a graph declares none, so the component entry names them.

``units: {blobX: px, speed: km/h}`` gives each named port a unit. A name from the built-in table
(:data:`fmionnx.core.units.BUILTIN_UNITS`) carries its definition, so connections convert it
like an FMU's unit; any other name (``px``) is compared as written. The interface of the model
file itself stays unit-less: ``inspect`` and the lock describe the file, not the entry.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from fmionnx.core import codes
from fmionnx.core.diagnostics import did_you_mean, one_of
from fmionnx.core.types import ComponentInterface
from fmionnx.core.units import builtin_unit
from fmionnx.kinds.base import KindProblem


def with_units(interface: ComponentInterface, units: Mapping[str, str]) -> ComponentInterface:
    """The interface with each named port's unit set (names that are no port are left out)."""
    ports = tuple(
        dataclasses.replace(
            port, unit=units[port.name], unit_definition=builtin_unit(units[port.name])
        )
        if port.name in units
        else port
        for port in interface.ports
    )
    return dataclasses.replace(interface, ports=ports)


def unit_problems(
    units: Mapping[str, str], interface: ComponentInterface
) -> tuple[KindProblem, ...]:
    """E018 for a ``units`` entry that names no port of the graph, or gives an empty unit."""
    names = [port.name for port in interface.ports]
    problems = []
    for port, unit in units.items():
        if port not in names:
            problems.append(
                KindProblem(
                    codes.UNKNOWN_OPTION,
                    f"`units`: the model has no port `{port}`",
                    "units",
                    hint=did_you_mean(port, names) or one_of(names),
                )
            )
        elif not unit.strip():
            problems.append(
                KindProblem(
                    codes.UNKNOWN_OPTION, f"`units`: port `{port}` is given an empty unit", "units"
                )
            )
    return tuple(problems)
