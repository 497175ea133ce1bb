"""A synchronous LSP client for tests: the real ``fmionnx lsp`` process over stdio.

pygls' own client (``pygls.lsp.client.LanguageClient``) runs on an asyncio loop in a thread of
its own; each method here sends one request or notification and waits for its answer, so
tests read like an editor session and need no asyncio plugin. The server's stderr is drained
continuously (an undrained pipe would block a chatty server) and kept for failure messages.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import threading
import time
from collections.abc import Callable, Coroutine
from pathlib import Path
from typing import Any, TypeVar

from lsprotocol import types
from pygls.lsp.client import LanguageClient

T = TypeVar("T")

#: Seconds to wait for an answer or for diagnostics (the first check loads every model).
TIMEOUT_S = 90.0


class Session:
    """One server process and the client talking to it."""

    def __init__(
        self, cwd: Path, env: dict[str, str] | None = None, args: tuple[str, ...] = ()
    ) -> None:
        """Start the server in ``cwd``: ``python -m fmionnx lsp``, or ``python ARGS``."""
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.client = LanguageClient("fmionnx-tests", "1")
        self.diagnostics: dict[str, list[types.Diagnostic]] = {}
        self.published = threading.Condition()
        self.log: list[str] = []
        self.stderr = bytearray()
        self.versions: dict[str, int] = {}

        @self.client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        def on_diagnostics(params: types.PublishDiagnosticsParams) -> None:
            with self.published:
                self.diagnostics[params.uri] = list(params.diagnostics)
                self.published.notify_all()

        @self.client.feature(types.WINDOW_LOG_MESSAGE)
        def on_log(params: types.LogMessageParams) -> None:
            self.log.append(params.message)

        environment = {**os.environ, **(env or {})}
        command = args or ("-m", "fmionnx", "lsp")
        self.call(self.client.start_io(sys.executable, *command, cwd=cwd, env=environment))
        server = self.client._server
        assert server is not None
        assert server.stderr is not None
        self.process = server
        asyncio.run_coroutine_threadsafe(self._drain(server.stderr), self.loop)

    async def _drain(self, stream: asyncio.StreamReader) -> None:
        while chunk := await stream.read(65536):
            self.stderr += chunk

    def call(self, coroutine: Coroutine[Any, Any, T], timeout: float = TIMEOUT_S) -> T:
        """Run ``coroutine`` on the client's loop and wait for its result."""
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(timeout)

    def notify(self, send: Callable[[], None]) -> None:
        """Send a notification from the client's loop thread."""
        done = threading.Event()

        def run() -> None:
            try:
                send()
            finally:
                done.set()

        self.loop.call_soon_threadsafe(run)
        assert done.wait(TIMEOUT_S)

    # -- the editor's side of a session ---------------------------------------------------------

    def initialize(self) -> types.InitializeResult:
        result = self.call(
            self.client.initialize_async(
                types.InitializeParams(
                    capabilities=types.ClientCapabilities(),
                    process_id=os.getpid(),
                    root_uri=None,
                )
            )
        )
        self.notify(lambda: self.client.initialized(types.InitializedParams()))
        return result

    def open(self, path: Path, text: str | None = None) -> str:
        """Open ``path`` (its text from disk unless given); returns its URI."""
        uri = path.absolute().as_uri()
        body = path.read_text(encoding="utf-8") if text is None else text
        self.versions[uri] = 1
        with self.published:
            self.diagnostics.pop(uri, None)
        item = types.TextDocumentItem(uri=uri, language_id="yaml", version=1, text=body)
        self.notify(
            lambda: self.client.text_document_did_open(types.DidOpenTextDocumentParams(item))
        )
        return uri

    def change(self, uri: str, text: str) -> None:
        """Replace the whole text of an open file (as a full-text change)."""
        self.versions[uri] += 1
        with self.published:
            self.diagnostics.pop(uri, None)
        params = types.DidChangeTextDocumentParams(
            text_document=types.VersionedTextDocumentIdentifier(
                uri=uri, version=self.versions[uri]
            ),
            content_changes=[types.TextDocumentContentChangeWholeDocument(text=text)],
        )
        self.notify(lambda: self.client.text_document_did_change(params))

    def files_changed(self, *paths: Path) -> None:
        """Say that files changed on disk (as an editor's file watcher does)."""
        params = types.DidChangeWatchedFilesParams(
            changes=[
                types.FileEvent(uri=p.absolute().as_uri(), type=types.FileChangeType.Changed)
                for p in paths
            ]
        )
        with self.published:
            self.diagnostics.clear()
        self.notify(lambda: self.client.workspace_did_change_watched_files(params))

    def wait_diagnostics(self, uri: str, timeout: float = TIMEOUT_S) -> list[types.Diagnostic]:
        """The next diagnostics published for ``uri`` (after the last open or change)."""
        deadline = time.monotonic() + timeout
        with self.published:
            while uri not in self.diagnostics:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    msg = f"no diagnostics for {uri} in {timeout} s; stderr:\n{self.stderr_text()}"
                    raise AssertionError(msg)
                self.published.wait(remaining)
            return self.diagnostics[uri]

    def completion(self, uri: str, line: int, character: int) -> list[types.CompletionItem]:
        params = types.CompletionParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            position=types.Position(line=line, character=character),
        )
        result = self.call(self.client.text_document_completion_async(params))
        if result is None:
            return []
        return list(result.items) if isinstance(result, types.CompletionList) else list(result)

    def hover(self, uri: str, line: int, character: int) -> types.Hover | None:
        params = types.HoverParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            position=types.Position(line=line, character=character),
        )
        return self.call(self.client.text_document_hover_async(params))

    def definition(self, uri: str, line: int, character: int) -> list[types.Location]:
        params = types.DefinitionParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            position=types.Position(line=line, character=character),
        )
        result = self.call(self.client.text_document_definition_async(params))
        if result is None:
            return []
        if isinstance(result, types.Location):
            return [result]
        return [r for r in result if isinstance(r, types.Location)]

    def code_actions(
        self, uri: str, span: types.Range, diagnostics: list[types.Diagnostic]
    ) -> list[types.CodeAction]:
        params = types.CodeActionParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            range=span,
            context=types.CodeActionContext(diagnostics=diagnostics),
        )
        result = self.call(self.client.text_document_code_action_async(params))
        return [a for a in result or [] if isinstance(a, types.CodeAction)]

    def rename(
        self, uri: str, line: int, character: int, new_name: str
    ) -> types.WorkspaceEdit | None:
        params = types.RenameParams(
            text_document=types.TextDocumentIdentifier(uri=uri),
            position=types.Position(line=line, character=character),
            new_name=new_name,
        )
        return self.call(self.client.text_document_rename_async(params))

    def stderr_text(self) -> str:
        return self.stderr.decode("utf-8", "replace")[-4000:]

    def close(self) -> None:
        """Shut the server down as an editor does, and stop the client's loop."""
        with contextlib.suppress(Exception):
            self.call(self.client.shutdown_async(None), timeout=30)
            self.notify(lambda: self.client.exit(None))
        with contextlib.suppress(Exception):
            self.call(asyncio.wait_for(self.process.wait(), 30), timeout=35)
        if self.process.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                self.process.kill()
        with contextlib.suppress(Exception):
            self.call(self.client.stop(), timeout=10)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)


def apply(text: str, edits: list[types.TextEdit]) -> str:
    """``text`` with ``edits`` applied (positions in UTF-16 units, as sent)."""
    lines = text.split("\n")

    def offset(position: types.Position) -> int:
        before = sum(len(line) + 1 for line in lines[: position.line])
        line = lines[position.line] if position.line < len(lines) else ""
        units = 0
        index = 0
        while index < len(line) and units < position.character:
            units += 2 if ord(line[index]) > 0xFFFF else 1
            index += 1
        return before + index

    ordered = sorted(
        edits, key=lambda e: (e.range.start.line, e.range.start.character), reverse=True
    )
    for edit in ordered:
        start, end = offset(edit.range.start), offset(edit.range.end)
        text = text[:start] + edit.new_text + text[end:]
    return text
