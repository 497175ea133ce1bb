"""What a source FMU tells its build must stay inside the FMU.

``fmionnx build-fmu`` hands a supplier's FMU to cmake (:mod:`.build`), which writes the
model identifier, the source file names and the preprocessor definitions of
``modelDescription.xml`` (FMI 2 ``<SourceFiles>``) or ``sources/buildDescription.xml`` into a
CMake cache, one ``NAME:TYPE=value`` per line. So before anything is built:

* the model identifier, which names the library cmake writes into ``binaries/<platform>/``,
  must be a plain name (``../../x`` would write the library elsewhere);
* every source file and include folder must lie inside ``sources/``, links followed (a name
  like ``../../../elsewhere/secret.c`` would be compiled into the library);
* no value may hold a control character: a line break inside an XML attribute (``&#10;``)
  would add lines of its own to the CMake cache.

Compiling C code is trusting it (a ``#include`` can name any file); these checks keep the
*file names the description gives* inside the FMU, as everywhere else (E017).
"""

from __future__ import annotations

from pathlib import Path, PurePosixPath

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.xmlsafe import parse_safely
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION, check_model_identifier

BUILD_DESCRIPTION = "sources/buildDescription.xml"
_INTERFACES = ("CoSimulation", "ModelExchange", "ScheduledExecution")


def _plain_text(value: str, what: str, label: str) -> None:
    if any(ord(c) < 32 or c == "\x7f" for c in value):
        msg = f"`{label}`: {what} `{value!r}` holds a control character"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)


def _inside_sources(name: str, sources: Path, what: str, label: str) -> None:
    _plain_text(name, what, label)
    normal = PurePosixPath(name.replace("\\", "/"))
    if (
        not name
        or normal.is_absolute()
        or (len(name) > 1 and name[1] == ":")
        or ".." in normal.parts
        or not (sources / normal).resolve().is_relative_to(sources.resolve())
    ):
        msg = f"`{label}`: {what} `{name}` lies outside the FMU's sources folder"
        raise ModelError(codes.UNSAFE_ARCHIVE, msg)


def check_build_inputs(unpacked: Path) -> None:
    """Raise ModelError (E017) when the unpacked source FMU names anything outside itself."""
    sources = unpacked / "sources"
    description = parse_safely((unpacked / MODEL_DESCRIPTION).read_bytes(), MODEL_DESCRIPTION)
    for interface in _INTERFACES:
        for element in description.iterfind(interface):
            identifier = element.get("modelIdentifier") or ""
            _plain_text(identifier, "modelIdentifier", MODEL_DESCRIPTION)
            check_model_identifier(identifier)
            for file in element.iterfind("SourceFiles/File"):
                _inside_sources(file.get("name") or "", sources, "source file", MODEL_DESCRIPTION)
    build = unpacked / BUILD_DESCRIPTION
    if not build.is_file():
        return
    root = parse_safely(build.read_bytes(), BUILD_DESCRIPTION)
    for file in root.iter("SourceFile"):
        _inside_sources(file.get("name") or "", sources, "source file", BUILD_DESCRIPTION)
    for folder in root.iter("IncludeDirectory"):
        _inside_sources(folder.get("name") or "", sources, "include folder", BUILD_DESCRIPTION)
    for element in root.iter():
        if not isinstance(element.tag, str):  # comments, processing instructions
            continue
        for key, value in element.attrib.items():
            _plain_text(str(value), f"{element.tag} {key}", BUILD_DESCRIPTION)
