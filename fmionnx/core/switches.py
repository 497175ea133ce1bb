"""Environment switches that turn a speed-up off (``FMIONNX_COMPILE_CACHE=0`` and the like).

One reading of them for every switch, so that each accepts the same words.
"""

from __future__ import annotations

import os

#: The values that turn a switch off (compared without case or surrounding blanks).
OFF = frozenset({"0", "off", "no", "false"})
#: The values that turn on a speed-up this machine would not get by default.
ON = frozenset({"1", "on", "yes", "true"})


def switched_off(variable: str) -> bool:
    """Whether the environment variable ``variable`` is set to one of :data:`OFF`."""
    return os.environ.get(variable, "").strip().lower() in OFF


def switched_on(variable: str) -> bool:
    """Whether the environment variable ``variable`` is set to one of :data:`ON`."""
    return os.environ.get(variable, "").strip().lower() in ON
