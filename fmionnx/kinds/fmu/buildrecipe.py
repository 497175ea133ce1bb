"""What a source FMU says about its own compilation: sources, include folders, definitions.

Read from ``sources/buildDescription.xml`` (FMI 3, and FMI 2.0.4) when the FMU has one, else
from FMI 2 ``<SourceFiles>`` of ``modelDescription.xml``. fmionnx reads it itself rather than
through ``fmpy.build`` because fmpy drops what the standard says a build must honour: the
``<IncludeDirectory>`` elements, definitions without a value (fmpy writes ``NAME=None``), every
source file set but the first, and, for FMI 3, the rule that a shared library exports the
unprefixed function names (:data:`FMI3_NO_PREFIX`).

The caller has already checked every name to lie inside ``sources/`` and to hold no control
character (:mod:`.buildcheck`); this module adds that a definition is a C identifier and that
no value holds the ``;`` CMake would split a list at.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.xmlsafe import parse_safely
from fmionnx.kinds.fmu.buildcheck import BUILD_DESCRIPTION
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION

#: The macro of the FMI 3 headers (``fmi3Functions.h``) that turns ``FMI3_FUNCTION_PREFIX``
#: off: with it, ``fmi3DoStep`` is exported as ``fmi3DoStep``, as a shared library must.
FMI3_NO_PREFIX = "FMI3_OVERRIDE_FUNCTION_PREFIX"

_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

#: The ``language`` of a source file set -> (CMake language, standard variable, value).
LANGUAGES: dict[str, tuple[str, str]] = {
    "C89": ("C", "90"),
    "C90": ("C", "90"),
    "C99": ("C", "99"),
    "C11": ("C", "11"),
    "C17": ("C", "17"),
    "C18": ("C", "17"),
    "C23": ("C", "23"),
    "C++98": ("CXX", "98"),
    "C++03": ("CXX", "98"),
    "C++11": ("CXX", "11"),
    "C++14": ("CXX", "14"),
    "C++17": ("CXX", "17"),
    "C++20": ("CXX", "20"),
    "C++23": ("CXX", "23"),
}


@dataclass(frozen=True, slots=True)
class BuildRecipe:
    """One shared library to compile: names relative to ``sources/``, definitions for ``-D``."""

    model_identifier: str
    fmi_major: int
    sources: tuple[str, ...]
    include_dirs: tuple[str, ...]
    definitions: tuple[str, ...]
    standards: tuple[tuple[str, str], ...]


def _definition(name: str, value: str | None, label: str) -> str:
    if not _IDENTIFIER.match(name):
        msg = f"`{label}`: preprocessor definition `{name}` is not a C identifier"
        raise ModelError(codes.BAD_MODEL, msg)
    if value is None:
        return name
    if ";" in value:
        msg = f"`{label}`: the value of preprocessor definition `{name}` holds a `;`"
        raise ModelError(codes.BAD_MODEL, msg)
    return f"{name}={value}"


def read_recipe(unpacked: Path) -> BuildRecipe:
    """The recipe of the unpacked source FMU (its names already checked by buildcheck).

    Raises ModelError E012 when the FMU names no source file, no model identifier, or a
    definition that is not a C identifier, or a language fmionnx cannot compile.
    """
    description = parse_safely((unpacked / MODEL_DESCRIPTION).read_bytes(), MODEL_DESCRIPTION)
    major = 3 if (description.get("fmiVersion") or "").startswith("3") else 2
    interfaces = [description.find(tag) for tag in ("CoSimulation", "ModelExchange")]
    present = [element for element in interfaces if element is not None]
    identifier = next((e.get("modelIdentifier") for e in present if e.get("modelIdentifier")), "")
    if not identifier:
        msg = f"`{MODEL_DESCRIPTION}` names no co-simulation or model exchange model identifier"
        raise ModelError(codes.BAD_MODEL, msg)
    sources: dict[str, None] = {}
    includes: dict[str, None] = {"": None}  # sources/ itself, first
    definitions: dict[str, None] = {FMI3_NO_PREFIX: None} if major == 3 else {}
    languages: list[str] = []
    build = unpacked / BUILD_DESCRIPTION
    if build.is_file():
        root = parse_safely(build.read_bytes(), BUILD_DESCRIPTION)
        configurations = list(root.iter("BuildConfiguration"))
        chosen = next(
            (c for c in configurations if c.get("modelIdentifier") == identifier),
            configurations[0] if configurations else None,
        )
        for file_set in chosen.iter("SourceFileSet") if chosen is not None else ():
            if file_set.get("language"):
                languages.append(str(file_set.get("language")))
            for file in file_set.iter("SourceFile"):
                sources[file.get("name") or ""] = None
            for folder in file_set.iter("IncludeDirectory"):
                includes[folder.get("name") or ""] = None
            for item in file_set.iter("PreprocessorDefinition"):
                definitions[
                    _definition(item.get("name") or "", item.get("value"), BUILD_DESCRIPTION)
                ] = None
    else:
        for element in present:
            for file in element.iterfind("SourceFiles/File"):
                sources[file.get("name") or ""] = None
    if not sources:
        msg = "the source FMU names no source file to compile"
        raise ModelError(
            codes.BAD_MODEL,
            msg,
            hint=f"list them in `{BUILD_DESCRIPTION}` (FMI 3) or <SourceFiles> (FMI 2)",
        )
    standards: dict[str, str] = {}
    for language in languages:
        if language not in LANGUAGES:
            msg = f"`{BUILD_DESCRIPTION}`: language `{language}` cannot be compiled here"
            raise ModelError(codes.BAD_MODEL, msg, hint=f"known: {', '.join(LANGUAGES)}")
        cmake_language, standard = LANGUAGES[language]
        standards.setdefault(cmake_language, standard)
    return BuildRecipe(
        model_identifier=identifier,
        fmi_major=major,
        sources=tuple(sources),
        include_dirs=tuple(includes),
        definitions=tuple(definitions),
        standards=tuple(standards.items()),
    )
