"""Language server: how soon an edit of the reference system shows its diagnostics.

A real ``fmionnx lsp`` process is driven over stdio by pygls' client, as an editor drives it.
The reference system (``systems/sign_follower.yaml``) is opened, then edited ``--edits``
times, alternating a misspelt port (one E021) and the correct text (no diagnostic); each edit
is timed from the change notification to the diagnostics published for it. The server waits
0.15 s after a change for the next keystroke; that wait is part of what an editor sees, so it
is part of the time. Side by side: ``fmionnx validate`` of the same file from the shell (a
process start, imports, every model read), what a user would run without the server.

Target (issue 36): every refresh within 1 s; reported, not asserted. Run
``python benchmarks/lsp.py`` (under a minute on 2 cores), ``--quick`` for a smoke run.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lsprotocol import types
from pygls.lsp.client import LanguageClient

REPO = Path(__file__).resolve().parent.parent
REFERENCE = REPO / "systems" / "sign_follower.yaml"
TYPO = ("  - odometry.theta -> tracker.theta", "  - odometry.thta -> tracker.theta")
#: What each refresh must stay under (issue 36).
TARGET_S = 1.0


async def _session(edits: int, cache: Path) -> tuple[float, list[float]]:
    """(seconds to the first diagnostics, seconds of each edit's refresh)."""
    client = LanguageClient("fmionnx-bench", "1")
    published: asyncio.Queue[types.PublishDiagnosticsParams] = asyncio.Queue()

    @client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    def _diagnostics(params: types.PublishDiagnosticsParams) -> None:
        published.put_nowait(params)

    env = {**os.environ, "FMIONNX_CACHE": str(cache)}
    await client.start_io(sys.executable, "-m", "fmionnx", "lsp", cwd=REPO, env=env)
    server = client._server
    assert server is not None
    assert server.stderr is not None
    drain = asyncio.ensure_future(server.stderr.read())
    await client.initialize_async(types.InitializeParams(capabilities=types.ClientCapabilities()))
    client.initialized(types.InitializedParams())
    uri = REFERENCE.as_uri()
    text = REFERENCE.read_text(encoding="utf-8")
    typo = text.replace(*TYPO)
    start = time.perf_counter()
    client.text_document_did_open(
        types.DidOpenTextDocumentParams(types.TextDocumentItem(uri, "yaml", 1, text))
    )
    await _next(published, 1)
    first = time.perf_counter() - start
    refreshes = []
    for version in range(2, edits + 2):
        body = typo if version % 2 == 0 else text
        start = time.perf_counter()
        client.text_document_did_change(
            types.DidChangeTextDocumentParams(
                types.VersionedTextDocumentIdentifier(uri=uri, version=version),
                [types.TextDocumentContentChangeWholeDocument(text=body)],
            )
        )
        params = await _next(published, version)
        refreshes.append(time.perf_counter() - start)
        codes = [d.code for d in params.diagnostics]
        expected = ["E021"] if body is typo else []
        if codes != expected:
            msg = f"edit {version}: diagnostics {codes}, expected {expected}"
            raise RuntimeError(msg)
    await client.shutdown_async(None)
    client.exit(None)
    await asyncio.wait_for(server.wait(), 30)
    await client.stop()
    drain.cancel()
    return first, refreshes


async def _next(
    queue: asyncio.Queue[types.PublishDiagnosticsParams], version: int
) -> types.PublishDiagnosticsParams:
    while True:
        params = await asyncio.wait_for(queue.get(), 120)
        if params.version == version:
            return params


def _validate_seconds(repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "fmionnx", "validate", "--quiet", str(REFERENCE)],
            capture_output=True,
            check=True,
            cwd=REPO,
        )
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    """Time, print."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edits", type=int, default=20, help="edits timed (default 20)")
    parser.add_argument("--quick", action="store_true", help="2 edits, 1 validate: a smoke run")
    args = parser.parse_args()
    edits = 2 if args.quick else args.edits
    with tempfile.TemporaryDirectory(prefix="fmionnx-bench-lsp-") as cache:
        first, refreshes = asyncio.run(_session(edits, Path(cache)))
    validate = _validate_seconds(1 if args.quick else 3)
    median = statistics.median(refreshes)
    rows = [
        ("first diagnostics after open (cold: imports, every model read)", f"{first:.2f} s"),
        (f"refresh after an edit, median of {len(refreshes)}", f"{median:.3f} s"),
        ("refresh after an edit, slowest", f"{max(refreshes):.3f} s"),
        ("  of which the server's wait for the next keystroke", "0.150 s"),
        (
            f"`fmionnx validate` from the shell, median of {len(validate)}",
            f"{statistics.median(validate):.2f} s",
        ),
        ("refresh / validate", f"{median / statistics.median(validate):.2f}x"),
        (
            f"target: every refresh < {TARGET_S:g} s",
            "met" if max(refreshes) < TARGET_S else "MISSED",
        ),
    ]
    width = max(len(name) for name, _ in rows)
    print("fmionnx lsp: the reference system, edit -> diagnostics")
    for name, value in rows:
        print(f"  {name:<{width}}  {value}")


if __name__ == "__main__":
    main()
