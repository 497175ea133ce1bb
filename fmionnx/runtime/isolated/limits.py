"""Resource limits of an isolated model's process, set before the model is loaded.

An isolated model runs native code that can allocate without bound (a hostile FMU, a bug, a
model asked for an array of a billion elements at run time). Its process gets an address-space
limit (``RLIMIT_AS``, :data:`~fmionnx.core.resources.ISOLATED_BYTES`): past it, an allocation
fails inside the model instead of the machine's memory running out. What the model then does
(most crash, some report an error) ends the run as a fault naming the component, and the
fault says what the limit was and how to raise it. Both the soft and the hard limit are set,
so the model cannot lift it again. This is separate from the sandbox (:mod:`.sandbox`), which
confines files and network and applies only with ``--sandbox``: the memory limit always does.
"""

from __future__ import annotations

import resource

from fmionnx.core.errors import ModelError
from fmionnx.core.resources import ISOLATED_BYTES


def limit_address_space() -> int | None:
    """Limit this process's address space; the limit set (None: left as it was, as when the
    setting is malformed: the supervisor refuses that before it starts a child)."""
    try:
        wanted = ISOLATED_BYTES.value()
    except ModelError:
        return None
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = wanted if hard == resource.RLIM_INFINITY else min(wanted, hard)
    try:
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    except (ValueError, OSError):
        return None
    return limit


def memory_note() -> str:
    """What a fault of an isolated model adds about the memory limit (it may be the cause)."""
    try:
        limit = ISOLATED_BYTES.value()
    except ModelError:
        return ""
    return (
        f"; its process may use at most {limit} bytes of address space: if the model ran out "
        f"of memory, raise the environment variable {ISOLATED_BYTES.variable}"
    )
