"""The protocol stream carries nothing but the protocol: what a library or a model writes to
stdout while the server works (Python's print, or C writing to file descriptor 1) goes to
stderr, and the editor's requests are still answered."""

from __future__ import annotations

from pathlib import Path

from tests.lsp.client import Session

#: The real server, whose hover also writes to stdout the ways a library can.
NOISY = """\
import os, sys
import fmionnx.lsp.server as server
real = server.hover
def noisy(*args, **kwargs):
    print("a library's print", end="")
    sys.stdout.flush()
    os.write(1, b"a C library's write")  # no newline: glued to the next header, if it got there
    return real(*args, **kwargs)
server.hover = noisy
server.serve()
"""


def test_what_is_printed_to_stdout_goes_to_stderr(tmp_path: Path) -> None:
    script = tmp_path / "noisy_server.py"
    script.write_text(NOISY, encoding="utf-8")
    system = tmp_path / "system.yaml"
    system.write_text("fmionnx: 1\nname: quiet\ncomponents: {}\n", encoding="utf-8")
    session = Session(tmp_path, env={"FMIONNX_CACHE": str(tmp_path / "cache")}, args=(str(script),))
    try:
        session.initialize()
        uri = session.open(system)
        session.wait_diagnostics(uri)
        for _ in range(2):
            found = session.hover(uri, 0, 2)  # the key `fmionnx`: its description
            assert found is not None
        assert session.process.returncode is None
    finally:
        session.close()
    assert "a library's print" in session.stderr_text()
    assert "a C library's write" in session.stderr_text()
