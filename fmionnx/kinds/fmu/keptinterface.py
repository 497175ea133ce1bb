"""FMU interfaces, kept between processes (``<cache>/fmu-interfaces``).

Reading an FMU's ports parses its model description with fmpy, which brings numpy: about a
quarter of a second of every compile that the compile cache cannot serve (a system file just
edited). For an FMU archive that answer depends only on the archive's bytes (and its name,
which the ports' origins carry), the reading code, the installed fmpy and the limits in force,
so it is kept under a key of exactly those, and a compile of an unchanged FMU reads it back
without importing fmpy. An unpacked FMU folder (whose library check follows the folder's
files and links) is read every time, as an FMU that fails is.

Entries are kept as every kept answer is (:mod:`fmionnx.core.keptentries`): private, signed
with this user's key, ignored when they do not check out or do not decode, bounded in size and
age as the compile cache is. ``FMIONNX_FMU_INTERFACES=0`` turns the keeping off.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from pathlib import Path

from fmionnx.core.datacodec import Codec
from fmionnx.core.keptentries import Entry, KeptAnswers, installed_package
from fmionnx.core.types import ComponentInterface
from fmionnx.kinds.cache import code_stamps, module_files, sha256_file

#: The store: ``FMIONNX_FMU_INTERFACES=0`` turns it off.
STORE = KeptAnswers(
    switch="FMIONNX_FMU_INTERFACES",
    folder="fmu-interfaces",
    format="fmionnx-fmu-interface-1",
    max_bytes=64 << 20,
    file_name="interface.json",
)

#: How interfaces are written and read back (:mod:`fmionnx.core.datacodec`).
_CODEC = Codec("kept FMU interface")


def kept_interface(path: Path, read: Callable[[], ComponentInterface]) -> ComponentInterface:
    """The interface of the FMU at ``path``: a kept one when an entry checks out, else
    ``read()``'s (kept when ``path`` is an archive). Raises as ``read`` does."""
    keyed = _entry(path) if STORE.enabled() and path.is_file() else None
    if keyed is not None:
        found = STORE.read_value(keyed[0], _CODEC, ComponentInterface)
        if found is not None:
            return dataclasses.replace(found, path=path)
    interface = read()
    # Kept only when read from the bytes the key hashed: an archive rebuilt between the two
    # would otherwise keep the new bytes' interface under the old bytes' key.
    if keyed is not None and interface.content_hash == keyed[1]:
        STORE.write_value(keyed[0], _CODEC, interface)
    return interface


def _entry(path: Path) -> tuple[Entry, str] | None:
    """The archive's entry and the sha256 of the archive it is for; None when it or fmpy
    cannot be stamped."""
    code = _code_stamps()
    if code is None:
        return None
    try:
        digest = sha256_file(path)
    except OSError:
        return None
    return STORE.entry([path.name, digest, *code]), digest


@functools.cache
def _code_stamps() -> tuple[str, ...] | None:
    """fmpy's installed package (found without importing it) and fmionnx's modules that read
    an FMU and define what an entry holds (the whole FMU kind, to be safe)."""
    from fmionnx.core import datacodec, keptentries, types, units, xmlsafe

    package = installed_package("fmpy")
    if package is None:
        return None
    kind = sorted(Path(__file__).parent.glob("*.py"))
    modules = module_files(types, units, datacodec, xmlsafe, keptentries)
    return code_stamps([package / "__init__.py", package / "model_description.py"], kind + modules)
