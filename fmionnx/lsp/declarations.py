"""Where a port or a component is declared, as a file and line an editor can open.

* An FMU's variables are declared in its ``modelDescription.xml``. An unpacked FMU has that
  file; a packed one (a ``.fmu`` zip) does not, and no editor opens a zip member, so its model
  description is copied, read-only, into fmionnx's cache folder (``lsp-models/<hash>/``) and the
  location points there. The copy is the archive's member byte for byte; the port's line is the
  one the interface reader recorded.
* A port of an XML model (a MuJoCo scene's sensor, actuator, camera or site) is the element
  with that name, found with the safe XML parser in the scene or a file it includes (only files
  inside the scene's folder, as the interface reader allows).
* A binary model (an ONNX file is protobuf) is shown by no text editor: its ports are written
  to a read-only text page in the cache (name, element type, shape, unit, description per
  line), and the location is the port's line there.

Which applies is decided by what the model is (an FMI kind's capability, the file's format),
never by a kind's name: a new kind gets the rule that fits its files.

Nothing here runs a model: files are read as data.
"""

from __future__ import annotations

import contextlib
import hashlib
import stat
from dataclasses import dataclass
from pathlib import Path

from fmionnx.core.archive import CORRUPT_ZIP_ERRORS, check_archive, open_zip
from fmionnx.core.cachedir import cache_folder, evict, touch
from fmionnx.core.errors import ModelError
from fmionnx.core.safewrite import write_bytes_atomic
from fmionnx.core.types import Causality, ComponentInterface, Port
from fmionnx.core.xmlsafe import parse_safely
from fmionnx.kinds.base import FMI
from fmionnx.kinds.registry import COMPONENT_KINDS

#: The cache folder of the copies made for editors.
CACHE_NAME = "lsp-models"
#: Bounds of that folder (copies are small: model descriptions and text pages).
_MAX_BYTES = 256 * 1024**2
_MAX_DAYS = 30

MODEL_DESCRIPTION = "modelDescription.xml"


@dataclass(frozen=True, slots=True)
class Place:
    """A 1-based line of a file (0: the file as a whole)."""

    file: Path
    line: int = 0


def _entry(interface: ComponentInterface, label: str) -> Path:
    """A cache entry for the model: its content hash (or its path's) names it."""
    key = interface.content_hash or hashlib.sha256(str(interface.path).encode()).hexdigest()
    return cache_folder(CACHE_NAME) / f"{key[:24]}-{label}"


def _write_read_only(path: Path, data: bytes) -> Path:
    """``data`` at ``path`` (kept when already there with the same bytes), mode 0444."""
    with contextlib.suppress(OSError):
        if path.is_file() and not path.is_symlink() and path.read_bytes() == data:
            touch(path.parent)
            return path
    path.parent.mkdir(parents=True, exist_ok=True)
    # A new file renamed over the name: an old copy (read-only) or a link planted there is
    # replaced, never written through; the mode is set on the file just written.
    write_bytes_atomic(path, data)
    with contextlib.suppress(OSError):
        path.chmod(stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH)
    with contextlib.suppress(OSError):
        evict(path.parent.parent, keep=path.parent, max_bytes=_MAX_BYTES, max_days=_MAX_DAYS)
    return path


#: Copies made by this process: (FMU path, content hash) -> the copy (and its root's line).
_COPIES: dict[tuple[str, str], tuple[Path, int]] = {}


def model_description_file(interface: ComponentInterface) -> Path | None:
    """A ``modelDescription.xml`` of the FMU an editor can open, or None when unreadable."""
    fmu = interface.path
    if fmu.is_dir():
        candidate = fmu / MODEL_DESCRIPTION
        return candidate if candidate.is_file() else None
    known = _COPIES.get((str(fmu), interface.content_hash))
    if known is not None and known[0].is_file() and not known[0].is_symlink():
        return known[0]
    copy = _copy_description(interface)
    if copy is not None and interface.content_hash:
        _COPIES[(str(fmu), interface.content_hash)] = (copy, _root_line(copy))
    return copy


def _copy_description(interface: ComponentInterface) -> Path | None:
    fmu = interface.path
    try:
        with open_zip(fmu) as archive:
            check_archive(archive)
            data = archive.read(MODEL_DESCRIPTION)
    except (ModelError, KeyError, OSError, *CORRUPT_ZIP_ERRORS):
        return None
    return _write_read_only(_entry(interface, fmu.name) / MODEL_DESCRIPTION, data)


def _is_fmi(interface: ComponentInterface) -> bool:
    kind = COMPONENT_KINDS.get(interface.kind)
    return kind is not None and FMI in kind.capabilities


def _is_binary(path: Path) -> bool:
    """A model file no editor shows as text (a NUL byte near its start)."""
    try:
        with path.open("rb") as stream:
            return b"\0" in stream.read(8192)
    except OSError:
        return False


def port_place(interface: ComponentInterface, port: Port) -> Place | None:
    """Where ``port`` is declared in its model, or None when no file says.

    By what the model file is, not by kind name: an FMI model's description; an XML model's
    element of that name; a binary model's page; a text model's line the reader recorded.
    """
    if _is_fmi(interface):
        xml = model_description_file(interface)
        if xml is None:
            return None
        return Place(xml, port.origin.line if port.origin is not None else 0)
    if interface.path.suffix.lower() == ".xml":
        return xml_element(interface.path, port.name)
    if _is_binary(interface.path):
        page, lines = binary_page(interface)
        return Place(page, lines.get(port.name, 0)) if page is not None else None
    line = port.origin.line if port.origin is not None else 0
    return Place(interface.path, line) if interface.path.is_file() else None


def model_place(interface: ComponentInterface) -> Place | None:
    """Where the model itself is: the FMU's model description (its root element), the page
    of a binary model, the model file."""
    if _is_fmi(interface):
        xml = model_description_file(interface)
        if xml is None:
            return None
        known = _COPIES.get((str(interface.path), interface.content_hash))
        return Place(xml, known[1] if known is not None else _root_line(xml))
    if _is_binary(interface.path):
        page, _ = binary_page(interface)
        return Place(page, 1) if page is not None else None
    return Place(interface.path, 1) if interface.path.is_file() else None


def _root_line(xml: Path) -> int:
    try:
        return int(parse_safely(xml.read_bytes(), xml.name).sourceline or 1)
    except (ModelError, OSError):
        return 1


def xml_element(model: Path, port: str) -> Place | None:
    """The element of an XML model (or a file it includes) named like ``port``.

    A port named after an element and a quantity of it (a MuJoCo site's ``B.pos``) is found
    at the element (``B``) when no element has the whole name.
    """
    found = named_element(model, port)
    if found is None and "." in port:
        found = named_element(model, port.rpartition(".")[0])
    return found


def named_element(scene: Path, name: str, tags: tuple[str, ...] = ()) -> Place | None:
    """The first element whose ``name`` is ``name`` (of one of ``tags`` when given) in the XML
    file ``scene`` or a file it includes (``<include file=...>`` inside its folder), or None."""
    folder = scene.parent.resolve()
    pending = [scene]
    seen: set[Path] = set()
    while pending and len(seen) < 256:
        current = pending.pop(0)
        try:
            resolved = current.resolve()
            if resolved in seen or (current != scene and not resolved.is_relative_to(folder)):
                continue
            seen.add(resolved)
            root = parse_safely(current.read_bytes(), current.name)
        except (ModelError, OSError, RuntimeError):
            continue
        for element in root.iter():
            tag = element.tag if isinstance(element.tag, str) else ""
            if element.get("name") == name and (not tags or tag in tags):
                return Place(current, int(element.sourceline or 0))
        for include in root.iter("include"):
            file = include.get("file")
            if file:
                pending.append(current.parent / file)
    return None


def binary_page(interface: ComponentInterface) -> tuple[Path | None, dict[str, int]]:
    """The read-only text page of a binary model's ports (an ONNX graph's inputs and outputs),
    and each port's line on it."""
    lines = [
        f"# {interface.path.name}: the inputs and outputs fmionnx reads from the model",
        "# (a read-only page written for the editor: the model file itself is binary)",
        "",
    ]
    where: dict[str, int] = {}
    for title, causality in (("inputs", Causality.INPUT), ("outputs", Causality.OUTPUT)):
        lines.append(f"{title}:")
        for port in interface.with_causality(causality):
            where[port.name] = len(lines) + 1
            unit = f"  [{port.unit}]" if port.unit else ""
            about = f"  # {port.description}" if port.description else ""
            lines.append(f"  {port.name}: {port.dtype.value}{port.shape_text()}{unit}{about}")
        lines.append("")
    for key, value in interface.facts:
        if value and "\n" not in value:
            lines.append(f"# {key}: {value}")
    data = ("\n".join(lines) + "\n").encode("utf-8")
    page = _entry(interface, interface.path.name) / f"{interface.path.name}.txt"
    try:
        return _write_read_only(page, data), where
    except OSError:
        return None, where
