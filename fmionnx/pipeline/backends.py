"""The backend table: one entry per way of running a compiled system.

A new backend is one module (a :class:`~fmionnx.runtime.backend.Backend` with its options
type) and one entry here; ``--backend`` lists the table's names, and the CLI, the Python API
and studies reach it through :func:`backend_entry` (``tests/architecture/test_backend_seam.py``
adds one). Entries are classes imported lazily (a ``module:Class`` path), so that starting the
CLI imports no backend and the ROS 2 stack loads only for a ROS 2 run.
"""

from __future__ import annotations

import importlib

from fmionnx.pipeline.errors import RequestError
from fmionnx.runtime.backend import Backend

#: Backend name -> ``module:class`` of its :class:`Backend`.
BACKENDS: dict[str, str] = {
    "inprocess": "fmionnx.backends.inprocess:InProcessBackend",
    "ros2": "fmionnx.backends.ros2.backend:Ros2Backend",
}


def backend_entry(name: str) -> type[Backend]:
    """The backend class called ``name``; RequestError listing the names otherwise."""
    where = BACKENDS.get(name)
    if where is None:
        names = sorted(BACKENDS)
        listed = ", ".join(f"`{n}`" for n in names[:-1]) + f" or `{names[-1]}`"
        msg = f"--backend must be {listed}, not `{name}`"
        raise RequestError(msg)
    module, _, attribute = where.partition(":")
    backend = getattr(importlib.import_module(module), attribute)
    if not (isinstance(backend, type) and issubclass(backend, Backend)):
        msg = f"`{where}` in the backend table is not a Backend"
        raise TypeError(msg)
    return backend


def taken_elsewhere(names: set[str], backend: str) -> dict[str, str]:
    """For each option in ``names``, the other backends that take it (``ros2``, or
    ``a or b``), for a message that says where an option belongs."""
    found: dict[str, str] = {}
    for name in sorted(names):
        owners = [
            other for other in sorted(BACKENDS)
            if other != backend and name in backend_entry(other).options_type.names()
        ]  # fmt: skip
        if owners:
            found[name] = " or ".join(owners)
    return found
