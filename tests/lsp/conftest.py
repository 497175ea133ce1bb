"""One real ``fmionnx lsp`` process for the module's tests, and a scratch copy of the
reference system's folder layout (``systems/`` beside ``build/`` and ``models/``)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import BUILT_MODELS, REPO
from tests.lsp.client import Session


@pytest.fixture(autouse=True)
def _own_cache(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """In-process tests write the editor copies (``lsp-models/``) into a cache of their own,
    never the user's."""
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path_factory.mktemp("lsp-own-cache")))


@pytest.fixture(scope="session")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with ``systems/`` (where tests write their files) and links to the built
    models and the MuJoCo scene, so the reference system's relative paths hold."""
    if not BUILT_MODELS.is_dir():
        msg = f"{BUILT_MODELS} is missing: run `make models` first (make test does)"
        raise FileNotFoundError(msg)
    root = tmp_path_factory.mktemp("lsp-workspace")
    (root / "systems").mkdir()
    (root / "build").mkdir()
    (root / "build" / "models").symlink_to(BUILT_MODELS)
    (root / "models").symlink_to(REPO / "models")
    return root


@pytest.fixture(scope="session")
def server(workspace: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Session]:
    """The server, initialized; its cache folder is the test's own."""
    cache = tmp_path_factory.mktemp("lsp-cache")
    session = Session(workspace, env={"FMIONNX_CACHE": str(cache)})
    try:
        session.initialize()
        yield session
    finally:
        session.close()


REFERENCE = REPO / "systems" / "sign_follower.yaml"


def reference_text() -> str:
    return REFERENCE.read_text(encoding="utf-8")
