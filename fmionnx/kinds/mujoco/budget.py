"""What a MuJoCo scene would cost, counted from its XML before MuJoCo compiles it.

A scene of a kilobyte can ask MuJoCo for gigabytes or for minutes: ``<replicate count=
"1000000000">`` around one geom, a ``<hfield nrow="40000" ncol="40000">``, a built-in texture of
30000 x 30000 pixels, a ``<flexcomp count="1500 1500 1">``, ``<size memory="100G">``. MuJoCo's
compiler allocates what the XML says and takes time quadratic in the number of elements, and
it cannot be interrupted. So before it sees the scene, the XML (every included file too) is
read with the safe parser and measured:

* **elements** (:data:`~fmionnx.core.resources.SCENE_ELEMENTS`): every XML element of the scene
  once includes are put in place and each ``replicate`` repeats its content ``count`` times;
  ``flexcomp`` and ``composite`` count three per point of their ``count`` (a body, its joint
  and its geom); a model ``<attach>``\\ ed counts its whole file. Counting multiplies, it never
  iterates: a ``replicate`` of a billion costs one multiplication.
* **bytes** (:data:`~fmionnx.core.resources.SCENE_BYTES`): height fields
  (:data:`HFIELD_CELL_BYTES` a cell), textures (:data:`TEXTURE_PIXEL_BYTES` a pixel, six
  faces for a cube or skybox; a PNG's size is read from its header, since a small PNG can
  decode to gigabytes), ``<size memory>`` and
  ``nuserdata``. Once compiled, the arena MuJoCo sizes for the simulation's data (it grows
  with the square of the degrees of freedom) is checked before ``MjData`` allocates it.

Every file the scene names (includes, meshes, textures, height fields, skins, models) must be
a regular file within :data:`~fmionnx.core.resources.MODEL_FILE_BYTES`: a FIFO or a device
would make MuJoCo's reader wait or read for ever. An include or an attached model that cannot
be read is E010 naming it and where it is named (``the included file `parts.xml` at
`scene.xml:3```), not the scene, which exists. Which files may be named (inside the scene's
folder) is :mod:`.files`' concern; this module only measures.
"""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import read_regular, regular_size
from fmionnx.core.resources import MODEL_FILE_BYTES, SCENE_BYTES, SCENE_ELEMENTS
from fmionnx.core.xmlsafe import parse_safely

#: Bytes MuJoCo takes at its peak per height-field cell, compiling the scene and making its
#: data: measured 16-17 (MuJoCo 3, 4 to 57 million cells), with a margin. Counting the 4
#: bytes a cell keeps in the model let a scene declared at 0.7 GB take 2.9 GB (found by
#: fuzzing, issue 38).
HFIELD_CELL_BYTES = 20
#: The same per texture pixel: measured 6 for a built-in texture of 8 to 64 million pixels.
TEXTURE_PIXEL_BYTES = 8

#: Includes and attached models followed at most (a cycle is refused before this).
MAX_FILES = 256
#: Elements one point of a ``flexcomp`` or ``composite`` stands for.
PER_POINT = 3
#: Attributes that name a file MuJoCo reads (textures of a cube have one per face).
_FILE_ATTRIBUTES = (
    "file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback",
)  # fmt: skip
#: ``<size memory>`` suffixes (MuJoCo's: powers of 1024).
_SUFFIXES = {"": 1, "K": 1024, "M": 1024**2, "G": 1024**3, "T": 1024**4, "P": 1024**5, "E": 1024**6}
#: Digits of a number read as it is written; a longer one is taken as 10^this (found by
#: fuzzing: `<size memory="1000...0">` of 5001 digits raised Python's ValueError).
_DIGITS = 30
_MEMORY = re.compile(r"\s*(\d+)\s*([KMGTPE]?)\s*", re.IGNORECASE)
_PNG = b"\x89PNG\r\n\x1a\n"
#: ``<size>`` attributes that are counts of something allocated per model.
_SIZE_COUNTS = (
    "nkey", "nuser_body", "nuser_jnt", "nuser_geom", "nuser_site", "nuser_cam",
    "nuser_tendon", "nuser_actuator", "nuser_sensor", "nconmax", "njmax",
)  # fmt: skip


def _tag(element: Any) -> str:
    return element.tag if isinstance(element.tag, str) else ""


def _number(text: str | None) -> int:
    """A non-negative whole number as MuJoCo reads it; anything else is MuJoCo's to refuse."""
    try:
        return max(0, int(float(text))) if text is not None else 0
    except (ValueError, OverflowError):
        return 0


def _elements(count: int) -> str:
    return "1 element" if count == 1 else f"{count} elements"


def _numbers(text: str | None) -> list[int]:
    return [_number(part) for part in (text or "").split()]


@dataclass
class _Scene:
    """The measuring of one scene: its folder, the parsed files, the running totals."""

    scene: Path
    folder: Path
    elements_limit: int
    bytes_limit: int
    files: dict[Path, Any] = field(default_factory=dict)
    counted: dict[Path, int] = field(default_factory=dict)
    open_files: list[Path] = field(default_factory=list)
    declared_bytes: int = 0

    # -- files ------------------------------------------------------------------------------

    def where(self, file: Path, element: Any) -> str:
        line = getattr(element, "sourceline", None)
        return f"`{file.name}:{line}`" if line else f"`{file.name}`"

    def root(self, file: Path, named_by: str | None = None) -> Any:
        """The parsed XML of ``file``. ``named_by`` says where an included or attached file
        is named (``the included file `parts.xml` at `scene.xml:3```): one that cannot be read is
        then E010 naming it and that place, not the scene (an OSError for the scene itself
        is the caller's to report)."""
        key = file.resolve()
        if key not in self.files:
            if len(self.files) >= MAX_FILES:
                msg = f"`{self.scene.name}` includes or attaches more than {MAX_FILES} files"
                raise ModelError(codes.UNSAFE_ARCHIVE, msg)
            try:
                data = read_regular(file, MODEL_FILE_BYTES, f"the scene file `{file.name}`")
            except OSError as exc:
                if named_by is None:
                    raise
                reason = exc.strerror or str(exc)
                msg = f"`{self.scene.name}`: {named_by} cannot be read: {reason}"
                raise ModelError(
                    codes.FILE_NOT_FOUND,
                    msg,
                    hint="name a file that exists, relative to the scene's folder",
                ) from None
            self.files[key] = parse_safely(data, file.name)
        return self.files[key]

    def named(self, value: str, base: Path) -> Path:
        return base / value

    # -- elements ---------------------------------------------------------------------------

    def count_file(self, file: Path, named_by: str | None = None) -> int:
        """Elements of ``file``'s tree (its root's content), includes and attaches expanded;
        ``named_by`` as for :meth:`root`."""
        key = file.resolve()
        if key in self.counted:
            return self.counted[key]
        if key in self.open_files:
            msg = f"`{self.scene.name}`: `{file.name}` includes or attaches itself"
            raise ModelError(codes.BAD_MODEL, msg, hint="MuJoCo cannot expand a cycle of includes")
        self.open_files.append(key)
        try:
            root = self.root(file, named_by)
            models = self.models(root, file)
            total = sum(self.count(child, file, models) for child in root)
        finally:
            self.open_files.pop()
        self.counted[key] = total
        return total

    def models(self, root: Any, file: Path) -> dict[str, tuple[Path, str]]:
        """The ``<model name file>`` assets of ``file`` (for its ``<attach model>``): each
        file, and where it is named."""
        return {
            str(element.get("name")): (
                self.named(str(element.get("file")), self.folder),
                f"the model file `{element.get('file')}` at {self.where(file, element)}",
            )
            for element in root.iter("model")
            if element.get("name") is not None and element.get("file") is not None
        }

    def count(self, element: Any, file: Path, models: dict[str, tuple[Path, str]]) -> int:
        """Elements ``element`` stands for (itself and its content), checked as it goes."""
        tag = _tag(element)
        if not tag:
            return 0
        self.measure(element, file)
        if tag == "include" and element.get("file") is not None:
            value = str(element.get("file"))
            named_by = f"the included file `{value}` at {self.where(file, element)}"
            return self.count_file(self.named(value, self.folder), named_by)
        inner = sum(self.count(child, file, models) for child in element)
        if tag == "replicate":
            total = inner * _number(element.get("count"))
            what = f'`<replicate count="{element.get("count")}">` repeats {_elements(inner)}'
        elif tag in ("flexcomp", "composite"):
            points = math.prod(_numbers(element.get("count")) or [0])
            total = 1 + inner + PER_POINT * points
            what = f'`<{tag} count="{element.get("count")}">` makes {points} points'
        elif tag == "attach" and element.get("model") in models:
            total = 1 + self.count_file(*models[str(element.get("model"))])
            what = f"the model attached as `{element.get('model')}`"
        else:
            total = 1 + inner
            what = f"`<{tag}>` holds {_elements(total)}"
        if total > self.elements_limit:
            msg = (
                f"`{self.scene.name}`: {what} at {self.where(file, element)}: the scene would "
                f"have {total} elements or more"
            )
            raise SCENE_ELEMENTS.exceeded(msg)
        return total

    # -- bytes and files --------------------------------------------------------------------

    def measure(self, element: Any, file: Path) -> None:
        """Files the element names, and the memory it declares (height fields, textures)."""
        tag = _tag(element)
        for attribute in _FILE_ATTRIBUTES:
            value = element.get(attribute)
            if value is not None:
                self.named_file(element, value, file)
        if tag == "hfield":
            cells = _number(element.get("nrow")) * _number(element.get("ncol"))
            if element.get("file") is not None:
                cells = max(cells, self.image_pixels(str(element.get("file"))))
            self.declare(HFIELD_CELL_BYTES * cells, f"`<hfield>` of {cells} cells", element, file)
        elif tag == "texture":
            self.texture(element, file)
        elif tag == "size":
            self.size(element, file)

    def candidates(self, value: str) -> list[Path]:
        """Where MuJoCo may look for ``value``: the scene's folder, alone or joined with the
        compiler's ``assetdir``/``meshdir``/``texturedir`` of any file of the scene."""
        found = [self.folder / value]
        for root in self.files.values():
            for compiler in root.iter("compiler"):
                for attribute in ("assetdir", "meshdir", "texturedir"):
                    folder = compiler.get(attribute)
                    if folder is not None:
                        found.append(self.folder / folder / value)
        return [path for path in dict.fromkeys(found) if path.exists()]

    def named_file(self, element: Any, value: str, file: Path) -> None:
        """Every file that ``value`` may name is a regular file of bounded size (a missing one
        is MuJoCo's to report)."""
        what = f"`{value}` (the file of `<{_tag(element)}>` at {self.where(file, element)})"
        for path in self.candidates(value):
            regular_size(path, MODEL_FILE_BYTES, what)

    def image_pixels(self, value: str) -> int:
        """Pixels a PNG declares in its header (the most of the files ``value`` may name); 0
        for other formats, whose data is as large as their file (bounded)."""
        pixels = 0
        for path in self.candidates(value):
            try:
                with path.open("rb") as stream:  # a regular file: checked by named_file
                    head = stream.read(24)
            except OSError:
                continue
            if head[:8] == _PNG and head[12:16] == b"IHDR":
                width, height = struct.unpack(">II", head[16:24])
                pixels = max(pixels, int(width) * int(height))
        return pixels

    def texture(self, element: Any, file: Path) -> None:
        """Built-in (``width`` x ``height``, six faces for a cube or skybox) and file pixels,
        :data:`TEXTURE_PIXEL_BYTES` each."""
        faces = 6 if element.get("type") in ("cube", "skybox") else 1
        pixels = _number(element.get("width")) * _number(element.get("height")) * faces
        for attribute in _FILE_ATTRIBUTES:
            value = element.get(attribute)
            if value is not None:
                pixels += self.image_pixels(value)
        self.declare(TEXTURE_PIXEL_BYTES * pixels, f"`<texture>` of {pixels} pixels", element, file)

    def size(self, element: Any, file: Path) -> None:
        memory = element.get("memory")
        if memory is not None:
            matched = _MEMORY.fullmatch(memory)
            if matched is not None:
                digits = matched.group(1)  # Python refuses to read over 4300 digits
                amount = int(digits) if len(digits) <= _DIGITS else 10**_DIGITS
                amount *= _SUFFIXES[matched.group(2).upper()]
                self.declare(amount, f'`<size memory="{memory}">`', element, file)
        user = _number(element.get("nuserdata"))
        self.declare(8 * user, f'`<size nuserdata="{user}">`', element, file)
        for attribute in _SIZE_COUNTS:
            value = _number(element.get(attribute))
            if value > self.elements_limit:
                msg = (
                    f'`{self.scene.name}`: `<size {attribute}="{value}">` at '
                    f"{self.where(file, element)}"
                )
                raise SCENE_ELEMENTS.exceeded(msg)

    def declare(self, amount: int, what: str, element: Any, file: Path) -> None:
        self.declared_bytes += amount
        if self.declared_bytes > self.bytes_limit:
            msg = (
                f"`{self.scene.name}`: {what} at {self.where(file, element)} takes the scene's "
                f"memory to {self.declared_bytes} bytes or more"
            )
            raise SCENE_BYTES.exceeded(msg)


def check_scene_budget(scene: Path) -> None:
    """Raise ModelError when the scene at ``scene`` (MJCF) exceeds what a scene may cost:
    E008 for its elements or memory, E011 for a file it names that is not a regular file,
    E008 for one too large. XML that is not well-formed is left to MuJoCo (which refuses it
    naming the line before it reads anything it names)."""
    measuring = _Scene(scene, scene.parent.resolve(), SCENE_ELEMENTS.value(), SCENE_BYTES.value())
    try:
        measuring.count_file(scene)
    except ModelError as exc:
        if exc.code == codes.BAD_MODEL and "not well-formed" in str(exc):
            return
        raise


def check_compiled_memory(model: Any, path: Path) -> None:
    """E008 when the simulation data of the compiled ``model`` would take more memory than a
    scene may: MuJoCo sizes its arena from the model (the square of the degrees of freedom
    for some of it), and ``MjData`` allocates it whole."""
    arena = int(getattr(model, "narena", 0)) + 8 * int(getattr(model, "nuserdata", 0))
    if arena > SCENE_BYTES.value():
        msg = (
            f"`{path.name}`: MuJoCo would allocate {arena} bytes for the simulation's data "
            f"({int(model.nv)} degrees of freedom, {int(model.nbody)} bodies)"
        )
        raise SCENE_BYTES.exceeded(msg)
