"""Connector names of FMU components: FMI 2 element names are 1-based, fmionnx indices 0-based.

In an SSD a connector of an FMU component names an FMI variable; FMI 2 exporters name array
elements ``x[1]`` ... ``x[n]`` (``x[1,2]`` for matrices), which the FMU reader groups into the
port ``x``. fmionnx endpoints index ports from 0 (``x[0]``), so names are shifted on the way in
and out. Names without brackets are unchanged; ONNX and MuJoCo connectors (our own types) use
fmionnx's 0-based indices as they are.
"""

from __future__ import annotations

import re

_ELEMENT = re.compile(r"^(?P<name>.+)\[(?P<index>\s*\d+\s*(?:,\s*\d+\s*)*)\]$")


def _shift(label: str, delta: int) -> str | None:
    match = _ELEMENT.match(label)
    if match is None:
        return label
    indices = [int(part) + delta for part in match.group("index").split(",")]
    if any(i < 0 for i in indices):
        return None
    return f"{match.group('name')}[{','.join(str(i) for i in indices)}]"


def fmi_to_port_label(label: str) -> str | None:
    """``x[1]`` -> ``x[0]``; None for a 0 index, which no FMI 2 element name has."""
    return _shift(label, -1)


def port_label_to_fmi(label: str) -> str:
    """``x[0]`` -> ``x[1]``."""
    shifted = _shift(label, 1)
    assert shifted is not None
    return shifted
