"""Text read from a file, made safe to show on a terminal: control characters made visible.

A model file is input nobody vetted: an ONNX port name, graph name, producer or metadata
entry can hold ``ESC [2J`` (clear the screen), ``ESC ] 0;...BEL`` (set the window title),
``ESC ] 8`` (a hyperlink the reader did not write) or a line break that splits a table's row.
Every renderer of text for people (``inspect``, the text and GitHub reports, ``graph``)
passes what it quotes from a file through :func:`printable`, so such a name shows as
``x\\x1b[2J`` and does nothing. Machine formats (JSON, SARIF) keep the text as it is: their
encoders escape it already.
"""

from __future__ import annotations

import re

#: C0 controls (tab and line break included: they break rows and lines), DEL and C1 controls
#: (``\x9b`` is a one-byte CSI to a terminal reading 8-bit controls), and the bidirectional
#: marks, embeddings, overrides and isolates (U+200E-F, U+202A-E, U+2066-9), which reorder
#: what follows them on the line: a name could make a message read other than it is.
_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u200e\u200f\u202a-\u202e\u2066-\u2069]")

#: The usual short spellings; every other control is ``\xNN``.
_SHORT = {"\t": "\\t", "\n": "\\n", "\r": "\\r"}


def _escaped(match: re.Match[str]) -> str:
    char = match.group()
    code = ord(char)
    return _SHORT.get(char) or (f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}")


def printable(text: str) -> str:
    """``text`` with every control character written as an escape (``\\x1b``, ``\\n``).

    Backslashes are left alone: a Windows path stays readable, and what matters here is that
    no byte reaching the terminal acts on it.
    """
    return _CONTROL.sub(_escaped, text)
