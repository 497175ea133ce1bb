"""The bound on all of one model's ports together, checked where a model is compiled and where
a compiled system is read back (a file written elsewhere is not trusted to respect it)."""

from __future__ import annotations

import math

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.resources import MAX_RANK, PORT_ELEMENTS, RANK_HINT
from fmionnx.core.types import ComponentInterface


def check_port_total(interface: ComponentInterface) -> None:
    """E008 when the ports of one model hold more elements together than allowed: each
    port's buffer is allocated when the run starts, so sixteen ports at the per-port limit
    would take gigabytes. A symbolic dimension counts 1 here, as in the runner (a
    connection that fills it is bounded by the port on its other end). E013 for a port of
    more dimensions than a buffer can have (:data:`~fmionnx.core.resources.MAX_RANK`)."""
    largest = PORT_ELEMENTS.value()
    total = 0
    for port in interface.ports:
        if len(port.shape) > MAX_RANK:
            msg = (
                f"`{interface.path.name}`: port `{port.name}` has {len(port.shape)} dimensions; "
                f"fmionnx holds at most {MAX_RANK}"
            )
            raise ModelError(codes.UNSUPPORTED_MODEL, msg, hint=RANK_HINT)
        total += math.prod(d for d in port.shape if isinstance(d, int))
        if total > largest:
            msg = (
                f"`{interface.path.name}`: its ports hold more than {largest} elements "
                f"together (at port `{port.name}`)"
            )
            raise PORT_ELEMENTS.exceeded(msg)
