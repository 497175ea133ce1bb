"""Model files travel to workers by content hash; each worker keeps them in a store of its own.

The driver packs every model the compiled system needs (one archive per content hash, made
from the same model-store layout as ``fmionnx compile --models``: ``<sha256>/<file>``, a scene
with the files it references -- never the rest of its folder, see
:func:`~fmionnx.kinds.registry.model_files`). Small archives travel inside every task; larger ones reach a worker once, as
the result of a task keyed by their content, which the scheduler can recompute if the worker
holding it dies (a very large model therefore travels through the scheduler once per worker;
see :func:`.engine._shared`). The worker unpacks an archive into its own store unless that
hash is already there. Nothing assumes a shared file system: a worker on another host needs only
fmionnx installed. The store's hash check is :func:`~fmionnx.compile.systemfile.relocate`:
a model is used only after its interface, read again from the unpacked file, has the hash the
compiled system names.
"""

from __future__ import annotations

import io
import re
import shutil
import tarfile
import tempfile
import threading
from collections.abc import Mapping
from pathlib import Path

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.systemfile import place_models

#: Folder of the model store inside a worker's local directory.
STORE_NAME = "fmionnx-models"

_UNPACKING = threading.Lock()
_SHA256 = re.compile(r"[0-9a-f]{64}")


def pack_models(system: CompiledSystem) -> dict[str, bytes]:
    """Every model ``system`` needs, as ``{sha256: tar archive of the store folder}``."""
    packed: dict[str, bytes] = {}
    with tempfile.TemporaryDirectory(prefix="fmionnx-pack-") as scratch:
        store = Path(scratch)
        for placed in place_models(system, store):
            folder = placed.parent
            if folder.name in packed:
                continue
            buffer = io.BytesIO()
            with tarfile.open(fileobj=buffer, mode="w") as archive:
                for item in sorted(folder.iterdir()):
                    archive.add(item, arcname=item.name)
            packed[folder.name] = buffer.getvalue()
    return packed


def unpack_models(store: Path, packed: Mapping[str, bytes]) -> None:
    """Unpack the archives whose hash ``store`` does not hold yet (each folder appears whole:
    unpacked beside it, then renamed). Archive members that would land outside the folder
    (absolute names, ``..``, links out) are refused by tarfile's ``data`` filter."""
    with _UNPACKING:  # a worker with several threads unpacks each model once
        store.mkdir(parents=True, exist_ok=True)
        for digest, blob in packed.items():
            if not _SHA256.fullmatch(digest):
                msg = f"not a model's content hash: `{digest[:70]}`"
                raise ValueError(msg)
            folder = store / digest
            if folder.is_dir():
                continue
            staging = Path(tempfile.mkdtemp(prefix=f".{digest[:16]}-", dir=store))
            try:
                with tarfile.open(fileobj=io.BytesIO(blob), mode="r") as archive:
                    archive.extractall(staging, filter="data")
                staging.replace(folder)
            finally:
                shutil.rmtree(staging, ignore_errors=True)
