"""A request at a position below zero (a client's bug: the protocol's positions are unsigned)
is answered with the JSON-RPC error InvalidParams naming the field; it was dropped by pygls
before any handler ran, and the editor waited for an answer forever."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from lsprotocol import types
from pygls.exceptions import JsonRpcInvalidParams

from tests.lsp.client import Session

#: Seconds to wait for the answer: it comes at once, or (unanswered) never.
ANSWER_S = 15.0


def _below_zero(line: int, character: int) -> types.Position:
    """A Position lsprotocol would refuse to make: the hostile client's, as it goes on the wire."""
    position = types.Position(line=0, character=0)
    object.__setattr__(position, "line", line)  # attrs validates on set; a client may not
    object.__setattr__(position, "character", character)
    return position


def _document(uri: str) -> types.TextDocumentIdentifier:
    return types.TextDocumentIdentifier(uri=uri)


#: method -> the parameters of a request on ``uri`` at ``position``
REQUESTS: dict[str, Callable[[str, types.Position], Any]] = {
    types.TEXT_DOCUMENT_HOVER: lambda uri, at: types.HoverParams(_document(uri), at),
    types.TEXT_DOCUMENT_COMPLETION: lambda uri, at: types.CompletionParams(_document(uri), at),
    types.TEXT_DOCUMENT_DEFINITION: lambda uri, at: types.DefinitionParams(_document(uri), at),
    types.TEXT_DOCUMENT_PREPARE_RENAME: lambda uri, at: types.PrepareRenameParams(
        _document(uri), at
    ),
    types.TEXT_DOCUMENT_RENAME: lambda uri, at: types.RenameParams(_document(uri), at, "x"),
    types.TEXT_DOCUMENT_CODE_ACTION: lambda uri, at: types.CodeActionParams(
        _document(uri),
        types.Range(at, types.Position(line=0, character=1)),
        types.CodeActionContext(diagnostics=[]),
    ),
}


def _ask(server: Session, method: str, params: object) -> object:
    async def send() -> object:
        return await server.client.protocol.send_request_async(method, params)

    return server.call(send(), timeout=ANSWER_S)


@pytest.fixture(scope="module")
def opened(server: Session, workspace: Path) -> str:
    path = workspace / "systems" / "negative_positions.yaml"
    path.write_text("fmionnx: 1\nname: quiet\ncomponents: {}\n", encoding="utf-8")
    uri = server.open(path)
    server.wait_diagnostics(uri)
    return uri


@pytest.mark.parametrize("method", list(REQUESTS))
@pytest.mark.parametrize(("line", "character", "field"), [(-1, 0, "line"), (0, -3, "character")])
def test_a_negative_position_is_answered_with_invalid_params(
    server: Session, opened: str, method: str, line: int, character: int, field: str
) -> None:
    params = REQUESTS[method](opened, _below_zero(line, character))
    with pytest.raises(JsonRpcInvalidParams) as answer:
        _ask(server, method, params)
    message = str(answer.value)
    assert f"`{method}`" in message
    assert f"Position.{field} should be in range" in message
    assert "@ $.params." in message  # where in the request


def test_the_server_goes_on_answering_and_logs_no_traceback(server: Session, opened: str) -> None:
    with pytest.raises(JsonRpcInvalidParams):
        _ask(
            server,
            types.TEXT_DOCUMENT_HOVER,
            REQUESTS[types.TEXT_DOCUMENT_HOVER](opened, _below_zero(-5, -5)),
        )
    assert server.hover(opened, 0, 2) is not None  # the key `fmionnx`: its description
    assert server.process.returncode is None
    stderr = server.stderr_text()
    assert "Unable to deserialize message" not in stderr
    assert "Unable to handle message" not in stderr
    assert not [m for m in server.log if "internal error" in m]
