"""``--view``: which live view a run streams to, read from one word (no library imported).

``rerun`` spawns a Rerun viewer on this machine, or connects to the one already running
there; ``rerun+tcp://HOST:PORT`` (or the viewer's own ``rerun+http://HOST:PORT/proxy``)
connects to a viewer elsewhere. ``foxglove`` serves the run over Foxglove's WebSocket
protocol on localhost, port 8765; ``foxglove:PORT`` on another port (0: any free one, which
the run's first lines name). docs/viewing.md says what each shows.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

#: Foxglove's own default port.
FOXGLOVE_PORT = 8765
#: The Rerun viewer's default gRPC port.
RERUN_PORT = 9876

ViewKind = Literal["rerun", "foxglove"]

_REMOTE = re.compile(
    r"^rerun\+(?:tcp|http)://(?P<host>[^/:\s]+|\[[0-9a-fA-F:]+\]):(?P<port>\d+)(?:/proxy)?/?$"
)
_FOXGLOVE = re.compile(r"^foxglove(?::(?P<port>\d+))?$")


class ViewSpecError(ValueError):
    """A ``--view`` value that names no view (the request turns it into a usage error)."""


@dataclass(frozen=True, slots=True)
class ViewTarget:
    """One live view: its kind and where it is."""

    kind: ViewKind
    #: Rerun: the viewer's gRPC URL (``rerun+http://HOST:PORT/proxy``), None to spawn or
    #: connect to the local one. Foxglove: unused.
    url: str | None = None
    #: Foxglove: the WebSocket port (0: any free one).
    port: int = FOXGLOVE_PORT
    #: The ``--view`` value as given (messages quote it).
    given: str = ""

    def describe(self) -> str:
        """How the run's first lines name it."""
        if self.kind == "foxglove":
            return f"Foxglove WebSocket on ws://127.0.0.1:{self.port}"
        return f"Rerun viewer at {self.url}" if self.url else "Rerun viewer"


def parse_view(text: str) -> ViewTarget:
    """One ``--view`` value (module docstring); ViewSpecError when it names no view."""
    word = text.strip()
    if word == "rerun":
        return ViewTarget("rerun", given=word)
    remote = _REMOTE.match(word)
    if remote is not None:
        port = int(remote["port"])
        if not 0 < port < 65536:
            msg = f"--view `{text}`: the port must be 1..65535"
            raise ViewSpecError(msg)
        return ViewTarget("rerun", url=f"rerun+http://{remote['host']}:{port}/proxy", given=word)
    foxglove = _FOXGLOVE.match(word)
    if foxglove is not None:
        port = FOXGLOVE_PORT if foxglove["port"] is None else int(foxglove["port"])
        if not 0 <= port < 65536:
            msg = f"--view `{text}`: the port must be 0..65535 (0: any free one)"
            raise ViewSpecError(msg)
        return ViewTarget("foxglove", port=port, given=word)
    msg = (
        f"--view takes `rerun`, `rerun+tcp://HOST:PORT`, `foxglove` or `foxglove:PORT`, "
        f"not `{text}`"
    )
    raise ViewSpecError(msg)
