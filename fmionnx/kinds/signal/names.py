"""The ``signal`` kind's name and its port names' pattern, without pydantic: the kind's modules
that a compiled system's reader loads (the waveforms, the table reader) take them from here;
the entry's models (:mod:`.spec`) are loaded only to compile a system file."""

from __future__ import annotations

import re
from typing import Final

NAME: Final = "signal"
#: Port names a signal may define: plain identifiers, safe in endpoints and ROS 2 names.
PORT_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
