"""``fmionnx lsp``: the language server over stdio (pygls).

The protocol layer only: documents are checked by :mod:`fmionnx.lsp.analysis` on one worker
thread, where requests that read models run too (the compiler's caches and the model readers
are used from that thread alone), a change waits
:data:`SETTLE_SECONDS` for the next keystroke before it is checked, and requests answer from
the last check's outline with the editor's current text: completion never waits for the
check of the change just typed (only for a check already running to end, and for the first
check of a file just opened).

Bad input never stops the server:

* stdout carries the protocol and nothing else: the process's file descriptor 1 is moved to
  stderr before anything runs, so a library or a model printing (even from C) cannot corrupt
  the stream;
* every handler is guarded: a failure of fmionnx itself (a bug) is logged to the client in one
  line and the request answered with an empty result, never a traceback on the stream;
* a request whose parameters are not what the protocol allows (a negative position) is
  answered with the error InvalidParams (:class:`FmionnxProtocol`), not left unanswered;
* a file that does not parse is diagnostics like any other mistake (the compiler's own).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import os
import sys
import traceback
from collections.abc import Awaitable, Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

from cattrs import ClassValidationError
from cattrs.v import format_exception, transform_error
from lsprotocol import types
from pygls.exceptions import JsonRpcException, JsonRpcInvalidParams
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol
from pygls.uris import to_fs_path
from pygls.workspace import TextDocument

from fmionnx.core.sourcetext import source_lines
from fmionnx.lsp.actions import actions
from fmionnx.lsp.analysis import Analysis, DocumentKind, analyse, document_kind
from fmionnx.lsp.completion import complete
from fmionnx.lsp.declarations import Place
from fmionnx.lsp.definition import definition
from fmionnx.lsp.diagnostics import Published, convert, uri_of
from fmionnx.lsp.hover import hover
from fmionnx.lsp.outline import Outline
from fmionnx.lsp.rename import RenameError, component_at, rename
from fmionnx.lsp.ssd import complete_ssd, definition_ssd, hover_ssd

#: Seconds a change waits for the next one before the file is checked.
SETTLE_SECONDS = 0.15
#: Longest a request waits for a file's first check.
FIRST_CHECK_SECONDS = 60.0
#: Files whose change on disk can change an open file's diagnostics: models, SSP resources,
#: expected paths, other system files.
WATCHED = ["**/*.{fmu,onnx,xml,mjb,csv,ssv,ssm,ssd,yaml,yml}", "**/modelDescription.xml"]
#: Characters after which an editor asks for completion by itself.
TRIGGERS = [".", " ", "/", "(", ",", "[", ">"]

P = ParamSpec("P")
R = TypeVar("R")


class RequestFailedError(JsonRpcException):
    """An answer the user gets as an error message (LSP ``RequestFailed``)."""

    CODE = -32803


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("fmionnx")
    except PackageNotFoundError:
        from fmionnx import __version__

        return __version__


#: Whether the message pygls is decoding on this thread is a request (which gets an answer).
_DECODING_REQUEST: ContextVar[bool] = ContextVar("fmionnx_decoding_request", default=False)


@dataclass(frozen=True, slots=True)
class RefusedRequest:
    """A request whose parameters did not decode: answered with ``error``, handled by none."""

    jsonrpc: str
    id: int | str
    method: str
    error: JsonRpcInvalidParams


class FmionnxProtocol(LanguageServerProtocol):
    """pygls' protocol, except that a request with parameters the protocol does not allow is
    answered with the JSON-RPC error InvalidParams (-32602) naming the field.

    pygls decodes each message into lsprotocol's types before any handler runs, and those
    types refuse what the specification rules out (a negative ``line`` or ``character``, a
    missing field). pygls then logs "Invalid Params" and drops the message: the editor waits
    for an answer that never comes, and shows "Error in server". Here the request is answered.

    With an error rather than an empty result: a position below zero is never where a user's
    cursor is but a bug of the client, and an empty result would tell it "nothing here" and
    hide that. InvalidParams is the answer JSON-RPC defines for exactly this: every client
    settles the request on it (the wait ends) and logs it, where the message names the field
    and its fault for whoever fixes the client. An empty result could not be given
    generically either: the request never reached a handler that knows what "empty" is for it.

    ``protocol_cls`` is pygls' own extension point; :meth:`structure_message` and
    :meth:`handle_message` are public, and ``_send_response`` is how pygls itself answers.
    A notification that does not decode has no one to answer: pygls' handling stays.
    """

    def structure_message(self, data: dict[str, Any]) -> Any:
        """pygls' decoding; a request it refuses becomes a :class:`RefusedRequest` (and
        pygls' log of the refusal, a traceback, is dropped: the answer says it)."""
        request = _is_request(data)
        token = _DECODING_REQUEST.set(request)
        try:
            return super().structure_message(data)
        except JsonRpcInvalidParams as exc:
            if not request:
                raise
            method = str(data["method"])
            detail = _why_invalid(exc.__cause__)
            error = JsonRpcInvalidParams(f"Invalid Params of `{method}`: {detail}")
            return RefusedRequest(str(data["jsonrpc"]), data["id"], method, error)
        finally:
            _DECODING_REQUEST.reset(token)

    def handle_message(self, message: Any) -> None:
        """Answer a :class:`RefusedRequest` with its error; hand the rest to pygls."""
        if isinstance(message, RefusedRequest):
            self._send_response(message.id, None, message.error.to_response_error())
            return
        super().handle_message(message)


def _is_request(data: dict[str, Any]) -> bool:
    """A JSON-RPC request (it expects an answer), not a notification or a response."""
    return "method" in data and "error" not in data and isinstance(data.get("id"), (int, str))


def _why_invalid(cause: BaseException | None) -> str:
    """Each fault of a message that did not decode, with where: ``Position.line should be in
    range [0:2147483647], but was -1 @ $.params.position``."""
    if not isinstance(cause, ClassValidationError):
        return str(cause)

    def say(exc: BaseException, expected: type | None) -> str:
        return str(exc).rstrip(".") if type(exc) is ValueError else format_exception(exc, expected)

    return "; ".join(transform_error(cause, format_exception=say))


class FmionnxServer(LanguageServer):
    """The server's state: the last check and published diagnostics of each open file."""

    def __init__(self) -> None:
        super().__init__("fmionnx", _version(), protocol_cls=FmionnxProtocol)
        self.checker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="fmionnx-check")
        self.analyses: dict[str, Analysis] = {}
        self.outlines: dict[str, Outline] = {}
        self.pending: dict[str, asyncio.Task[None]] = {}
        #: target URI -> owner URI -> what the owner's check found in the target
        self.contributions: dict[str, dict[str, list[Published]]] = {}
        #: target URI -> the diagnostics last published for it (ranges in code points)
        self.published: dict[str, list[Published]] = {}

    # -- documents ----------------------------------------------------------------------------

    def path_of(self, uri: str) -> Path | None:
        """The file of a ``file:`` URI (None for an unsaved, untitled buffer)."""
        if not uri.startswith("file:"):
            return None
        path = to_fs_path(uri)
        return Path(path) if path else None

    def open_texts(self) -> dict[Path, str]:
        """Every open file's text, by path."""
        texts: dict[Path, str] = {}
        for uri, document in self.workspace.text_documents.items():
            path = self.path_of(uri)
            if path is not None:
                texts[path] = document.source
        return texts

    def lines_of(self, path: Path) -> Sequence[str]:
        """A file's lines: the editor's text when it is open, else what is on disk."""
        for uri, document in self.workspace.text_documents.items():
            if self.path_of(uri) == path:
                source: str = document.source
                return source.split("\n")
        return source_lines(path)

    def uri_for(self, path: Path) -> str:
        """The URI an open file is known by (the client's own), else the path's."""
        for uri in self.workspace.text_documents:
            found = self.path_of(str(uri))
            if found is not None and _same(found, path):
                return str(uri)
        return uri_of(path)

    def schedule(self, uri: str, delay: float) -> None:
        """Check ``uri`` after ``delay`` seconds, replacing a check not yet started."""
        previous = self.pending.get(uri)
        if previous is not None and not previous.done():
            previous.cancel()
        self.pending[uri] = asyncio.ensure_future(self._check(uri, delay))

    async def _check(self, uri: str, delay: float) -> None:
        await asyncio.sleep(delay)
        path = self.path_of(uri)
        if path is None or uri not in self.workspace.text_documents:
            return
        texts = self.open_texts()
        if path not in texts:
            return
        loop = asyncio.get_running_loop()
        try:
            analysis = await loop.run_in_executor(self.checker, analyse, path, texts)
        except Exception as exc:  # analyse guards itself; this is the net below it
            self.log_bug("checking", exc)
            return
        if uri not in self.workspace.text_documents:
            return  # closed meanwhile
        self.analyses[uri] = analysis
        if analysis.outline is not None:
            self.outlines[uri] = analysis.outline
        self.publish(uri, analysis)
        self._recheck_dependents(uri, path)

    def _recheck_dependents(self, uri: str, path: Path) -> None:
        """Studies open on a system file that just changed are checked again."""
        for other, analysis in list(self.analyses.items()):
            system = analysis.outline.system if analysis.outline is not None else None
            if other != uri and system is not None and _same(system.path, path):
                self.schedule(other, SETTLE_SECONDS)

    async def on_checker(self, work: Callable[P, R], *args: P.args, **kwargs: P.kwargs) -> R:
        """``work(...)`` on the checker's thread: the compiler's caches and the model readers
        (MuJoCo's among them) are used from that one thread only."""
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self.checker, functools.partial(work, *args, **kwargs))

    async def settled(self, uri: str) -> None:
        """Wait for the file's first check (a later one is not waited for)."""
        if uri in self.outlines or uri in self.analyses:
            return
        deadline = asyncio.get_running_loop().time() + FIRST_CHECK_SECONDS
        while uri not in self.analyses:
            task = self.pending.get(uri)
            remaining = deadline - asyncio.get_running_loop().time()
            if task is None or remaining <= 0:
                return
            with contextlib.suppress(asyncio.CancelledError, TimeoutError):
                await asyncio.wait_for(asyncio.shield(task), remaining)
            if task.done() and self.pending.get(uri) is task:
                return

    def forget(self, uri: str) -> None:
        """A closed file: its check, and what its check published anywhere, go."""
        task = self.pending.pop(uri, None)
        if task is not None:
            task.cancel()
        self.analyses.pop(uri, None)
        self.outlines.pop(uri, None)
        for target, owners in list(self.contributions.items()):
            if owners.pop(uri, None) is not None:
                self._send(target)

    # -- diagnostics --------------------------------------------------------------------------

    def publish(self, owner: str, analysis: Analysis) -> None:
        """Publish what ``owner``'s check found, in every file it points into."""
        by_file = convert(analysis, self.lines_of)
        found: dict[str, list[Published]] = {owner: by_file.pop(analysis.path, [])}
        for path, items in by_file.items():
            found.setdefault(self.uri_for(path), []).extend(items)
        targets = set(found)
        targets |= {t for t, owners in self.contributions.items() if owner in owners}
        for target in targets:
            owners = self.contributions.setdefault(target, {})
            if target in found:
                owners[owner] = found[target]
            else:
                owners.pop(owner, None)
            self._send(target)

    def _send(self, target: str) -> None:
        owners = self.contributions.get(target, {})
        merged: dict[tuple[Any, ...], Published] = {}
        for owner in sorted(owners, key=lambda o: o != target):  # the file's own check first
            for item in owners[owner]:
                lsp = item.lsp
                key = (lsp.range.start.line, lsp.range.start.character, lsp.code, lsp.message)
                merged.setdefault(key, item)
        items = list(merged.values())
        self.published[target] = items
        path = self.path_of(target)
        lines = self.lines_of(path) if path is not None else ()
        codec = self.workspace.position_codec
        diagnostics = []
        for item in items:
            shown = item.lsp
            with contextlib.suppress(IndexError, ValueError):
                shown = _with_range(shown, codec.range_to_client_units(lines, shown.range))
            diagnostics.append(shown)
        document = self.workspace.text_documents.get(target)
        self.text_document_publish_diagnostics(
            types.PublishDiagnosticsParams(
                uri=target,
                diagnostics=diagnostics,
                version=document.version if document is not None else None,
            )
        )

    # -- failures -----------------------------------------------------------------------------

    def log_bug(self, what: str, exc: BaseException) -> None:
        """One line to the client, the traceback to stderr (never the protocol stream)."""
        frames = traceback.extract_tb(exc.__traceback__)
        where = f" at {Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""
        message = f"fmionnx: internal error while {what}: {type(exc).__name__}: {exc}{where}"
        traceback.print_exception(exc, file=sys.stderr)
        with contextlib.suppress(Exception):
            self.window_log_message(types.LogMessageParams(types.MessageType.Error, message))


def _same(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return a == b


def _with_range(diagnostic: types.Diagnostic, span: types.Range) -> types.Diagnostic:
    return types.Diagnostic(
        range=span,
        message=diagnostic.message,
        severity=diagnostic.severity,
        code=diagnostic.code,
        source=diagnostic.source,
        related_information=diagnostic.related_information,
    )


def _guarded(
    server: FmionnxServer, what: str
) -> Callable[[Callable[P, Awaitable[R | None]]], Callable[P, Awaitable[R | None]]]:
    """A handler whose failure (a bug) is logged and answered with an empty result."""

    def wrap(handler: Callable[P, Awaitable[R | None]]) -> Callable[P, Awaitable[R | None]]:
        @functools.wraps(handler)
        async def guarded(*args: P.args, **kwargs: P.kwargs) -> R | None:
            try:
                return await handler(*args, **kwargs)
            except JsonRpcException:
                raise  # an answer meant for the user (a refused rename)
            except Exception as exc:
                server.log_bug(what, exc)
                return None

        return guarded

    return wrap


# -- the features -----------------------------------------------------------------------------


def make_server() -> FmionnxServer:
    """The server with every feature registered."""
    server = FmionnxServer()

    def document(uri: str) -> TextDocument:
        """The open document at ``uri``, else the file read from disk; a request about a
        file that is neither (never opened, then deleted) is refused in one line (it was an
        "internal error" with a traceback)."""
        doc = server.workspace.get_text_document(uri)
        if uri not in server.workspace.text_documents:
            try:
                doc.source  # noqa: B018 - read from disk: whether it can be
            except (OSError, UnicodeDecodeError, ValueError) as exc:
                reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else "unreadable"
                msg = f"`{uri}` is not open in the editor and cannot be read ({reason})"
                raise RequestFailedError(msg) from None
        return doc

    def at(doc: TextDocument, position: types.Position) -> tuple[int, int]:
        here = doc.position_codec.position_from_client_units(doc.lines, position)
        return here.line, here.character

    def to_client(doc: TextDocument, span: types.Range) -> types.Range:
        return doc.position_codec.range_to_client_units(doc.lines, span)

    def kind_of(uri: str, doc: TextDocument) -> DocumentKind:
        analysis = server.analyses.get(uri)
        if analysis is not None:
            return analysis.kind
        path = server.path_of(uri)
        return document_kind(path, doc.source) if path is not None else DocumentKind.OTHER

    async def settled_at(
        uri: str, position: types.Position
    ) -> tuple[TextDocument, int, int, DocumentKind, Outline | None]:
        """What a request at ``position`` works on, once the document's last change is
        analysed: the document, the line and column (server units), its kind and outline."""
        await server.settled(uri)
        doc = document(uri)
        line, column = at(doc, position)
        return doc, line, column, kind_of(uri, doc), server.outlines.get(uri)

    @server.feature(types.TEXT_DOCUMENT_DID_OPEN)
    @_guarded(server, "opening a file")
    async def did_open(params: types.DidOpenTextDocumentParams) -> None:
        server.schedule(params.text_document.uri, 0.0)

    @server.feature(types.TEXT_DOCUMENT_DID_CHANGE)
    @_guarded(server, "taking a change")
    async def did_change(params: types.DidChangeTextDocumentParams) -> None:
        server.schedule(params.text_document.uri, SETTLE_SECONDS)

    @server.feature(types.TEXT_DOCUMENT_DID_SAVE)
    @_guarded(server, "taking a save")
    async def did_save(params: types.DidSaveTextDocumentParams) -> None:
        # A saved file may be what another open file uses; models may have been rebuilt.
        for uri in list(server.workspace.text_documents):
            server.schedule(uri, 0.0 if uri == params.text_document.uri else SETTLE_SECONDS)

    @server.feature(types.INITIALIZED)
    @_guarded(server, "starting")
    async def initialized(params: types.InitializedParams) -> None:
        # Models are rebuilt outside the editor (`make models`, an FMU re-exported): ask the
        # client to say when one changes, where it can be asked.
        workspace = server.client_capabilities.workspace
        watched = workspace.did_change_watched_files if workspace is not None else None
        if watched is None or not watched.dynamic_registration:
            return
        options = types.DidChangeWatchedFilesRegistrationOptions(
            watchers=[types.FileSystemWatcher(glob_pattern=pattern) for pattern in WATCHED]
        )
        registration = types.Registration(
            id="fmionnx-models",
            method=types.WORKSPACE_DID_CHANGE_WATCHED_FILES,
            register_options=options,
        )
        try:
            await server.client_register_capability_async(types.RegistrationParams([registration]))
        except JsonRpcException:
            return  # refused: files saved in the editor still check everything again

    @server.feature(types.WORKSPACE_DID_CHANGE_WATCHED_FILES)
    @_guarded(server, "taking a changed file")
    async def watched_changed(params: types.DidChangeWatchedFilesParams) -> None:
        # A model (or an SSP resource, a path file) changed on disk: every open file is
        # checked again; an unchanged model is still not read again (its identity is the same).
        for uri in list(server.workspace.text_documents):
            server.schedule(uri, SETTLE_SECONDS)

    @server.feature(types.TEXT_DOCUMENT_DID_CLOSE)
    @_guarded(server, "closing a file")
    async def did_close(params: types.DidCloseTextDocumentParams) -> None:
        server.forget(params.text_document.uri)

    @server.feature(
        types.TEXT_DOCUMENT_COMPLETION, types.CompletionOptions(trigger_characters=TRIGGERS)
    )
    @_guarded(server, "completing")
    async def completion(params: types.CompletionParams) -> types.CompletionList | None:
        uri = params.text_document.uri
        doc, line, column, kind, outline = await settled_at(uri, params.position)
        if kind is DocumentKind.SSP:
            items = await server.on_checker(complete_ssd, doc.source, line, column, outline)
        else:
            items = await server.on_checker(complete, doc.source, line, column, kind, outline)
        for item in items:
            if isinstance(item.text_edit, types.TextEdit):
                item.text_edit = types.TextEdit(
                    to_client(doc, item.text_edit.range), item.text_edit.new_text
                )
        return types.CompletionList(is_incomplete=False, items=items)

    @server.feature(types.TEXT_DOCUMENT_HOVER)
    @_guarded(server, "hovering")
    async def on_hover(params: types.HoverParams) -> types.Hover | None:
        uri = params.text_document.uri
        doc, line, column, kind, outline = await settled_at(uri, params.position)
        codes = [
            str(item.lsp.code)
            for item in server.published.get(uri, [])
            if item.lsp.code is not None and _contains(item.lsp.range, line, column)
        ]
        found = await server.on_checker(hover, doc.source, line, column, kind, outline, codes)
        if kind is DocumentKind.SSP:
            about = await server.on_checker(hover_ssd, doc.source, line, column, outline)
            if about is not None:
                found = _with_text(found, about[0], about[1])
        if found is not None and found.range is not None:
            found.range = to_client(doc, found.range)
        return found

    @server.feature(types.TEXT_DOCUMENT_DEFINITION)
    @_guarded(server, "finding a definition")
    async def on_definition(params: types.DefinitionParams) -> list[types.Location] | None:
        uri = params.text_document.uri
        doc, line, column, kind, outline = await settled_at(uri, params.position)
        if kind is DocumentKind.SSP:
            place = await server.on_checker(definition_ssd, doc.source, line, column, outline)
            return [_location(place)] if place is not None else None
        found = await server.on_checker(definition, doc.source, line, column, kind, outline)
        return found or None

    @server.feature(
        types.TEXT_DOCUMENT_CODE_ACTION,
        types.CodeActionOptions(code_action_kinds=[types.CodeActionKind.QuickFix]),
    )
    @_guarded(server, "finding fixes")
    async def code_action(params: types.CodeActionParams) -> list[types.CodeAction] | None:
        uri = params.text_document.uri
        path = server.path_of(uri)
        if path is None:
            return None
        await server.settled(uri)
        doc = document(uri)
        span = doc.position_codec.range_from_client_units(doc.lines, params.range)
        wanted = types.Range(
            types.Position(line=span.start.line, character=span.start.character),
            types.Position(line=span.end.line, character=span.end.character),
        )
        found = actions(uri, path, doc.source, server.published.get(uri, []), wanted)
        for action in found:
            if action.edit is not None and action.edit.changes:
                for edits in action.edit.changes.values():
                    for edit in edits:
                        edit.range = to_client(doc, edit.range)
            if action.diagnostics:
                action.diagnostics = [
                    _with_range(d, to_client(doc, d.range)) for d in action.diagnostics
                ]
        return found or None

    @server.feature(types.TEXT_DOCUMENT_PREPARE_RENAME)
    @_guarded(server, "preparing a rename")
    async def prepare_rename(params: types.PrepareRenameParams) -> types.Range | None:
        uri = params.text_document.uri
        path = server.path_of(uri)
        doc = document(uri)
        if path is None or kind_of(uri, doc) is not DocumentKind.SYSTEM:
            return None
        line, column = at(doc, params.position)
        found = component_at(path, doc.source, line, column)
        return to_client(doc, found[1]) if found is not None else None

    @server.feature(types.TEXT_DOCUMENT_RENAME)
    @_guarded(server, "renaming")
    async def on_rename(params: types.RenameParams) -> types.WorkspaceEdit | None:
        uri = params.text_document.uri
        path = server.path_of(uri)
        doc = document(uri)
        if path is None or kind_of(uri, doc) is not DocumentKind.SYSTEM:
            msg = "only a component of a YAML system file can be renamed"
            raise RequestFailedError(msg)
        line, column = at(doc, params.position)
        try:
            edit = rename(uri, path, doc.source, line, column, params.new_name)
        except RenameError as exc:
            raise RequestFailedError(str(exc)) from None
        for edits in (edit.changes or {}).values():
            for text_edit in edits:
                text_edit.range = to_client(doc, text_edit.range)
        return edit

    return server


def _with_text(hover_found: types.Hover | None, text: str, span: types.Range) -> types.Hover:
    """``text`` first, then what ``hover_found`` says (a diagnostic's code)."""
    parts = [text]
    if hover_found is not None and isinstance(hover_found.contents, types.MarkupContent):
        parts.append(hover_found.contents.value)
    return types.Hover(
        types.MarkupContent(types.MarkupKind.Markdown, "\n\n---\n\n".join(parts)), span
    )


def _location(place: Place) -> types.Location:
    position = types.Position(line=max(place.line - 1, 0), character=0)
    return types.Location(uri_of(place.file), types.Range(position, position))


def _contains(span: types.Range, line: int, column: int) -> bool:
    start = (span.start.line, span.start.character)
    end = (span.end.line, span.end.character)
    return start <= (line, column) <= end


def _not_an_answer(record: logging.LogRecord) -> bool:
    """Whether pygls' log ``record`` is worth stderr: not when it is the traceback pygls logs
    for every error a handler raises, where the error is an answer meant for the user (a
    refused rename, a file that cannot be read), not a bug; nor the traceback it logs for a
    request that did not decode, which :class:`FmionnxProtocol` answers."""
    if _DECODING_REQUEST.get() and str(record.msg).startswith("Unable to deserialize"):
        return False
    error = record.exc_info[1] if record.exc_info else None
    return not isinstance(error, RequestFailedError)


def serve() -> None:
    """Run the server on stdin/stdout until the client says exit (or stdin closes)."""
    protocol_out = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # stray prints go to stderr
    sys.stdout = sys.stderr
    logging.getLogger("pygls").setLevel(logging.WARNING)
    logging.getLogger("pygls.protocol.json_rpc").addFilter(_not_an_answer)
    server = make_server()
    try:
        server.start_io(sys.stdin.buffer, protocol_out)
    finally:
        server.checker.shutdown(wait=False, cancel_futures=True)
