"""A component interface as plain data: the stable JSON form of ``fmionnx inspect``.

The dict layout is documented in ``docs/components.md`` and kept stable: keys are only ever
added. Non-finite floats (NaN and infinities are legal FMI start values) become the strings
``"nan"``, ``"inf"`` and ``"-inf"`` so that the output stays valid JSON.
"""

from __future__ import annotations

import math

from fmionnx.core.types import ComponentInterface, Port, Scalar

#: A JSON value as produced here.
Json = None | bool | int | float | str | list["Json"] | dict[str, "Json"]


def _scalar(value: Scalar) -> Json:
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return value


def _bound(port: Port, bound: float | None) -> Json:
    """An integer port's bound as an integer (a kept interface reads it back as a float)."""
    if bound is not None and port.dtype.is_integer:
        return int(bound)
    return bound


def port_to_dict(port: Port) -> dict[str, Json]:
    """One port: name, causality, dtype, shape (list), unit, start, ... (see the docs)."""
    return {
        "name": port.name,
        "causality": port.causality.value,
        "dtype": port.dtype.value,
        "shape": list(port.shape),
        "unit": port.unit,
        "start": None if port.start is None else [_scalar(v) for v in port.start],
        "min": _bound(port, port.bounds[0]),
        "max": _bound(port, port.bounds[1]),
        "variability": port.variability,
        "description": port.description,
        "depends_on": None if port.depends_on is None else list(port.depends_on),
        "vrs": list(port.vrs),
        "origin": None if port.origin is None else str(port.origin),
    }


def interface_to_dict(interface: ComponentInterface) -> dict[str, Json]:
    """``{"kind", "path", "content_hash", "facts", "default_experiment", "ports"}``."""
    experiment = interface.default_experiment
    return {
        "kind": interface.kind,
        "path": str(interface.path),
        "content_hash": interface.content_hash,
        "facts": dict(interface.facts),
        "default_experiment": None
        if experiment is None
        else {
            "start": experiment.start,
            "stop": experiment.stop,
            "step": experiment.step,
            "tolerance": experiment.tolerance,
        },
        "ports": [port_to_dict(p) for p in interface.ports],
    }
