"""``fmionnx validate model.fmu``: FMPy's validation, and the binary a run would load.

Reading the interface already validated ``modelDescription.xml`` against the FMI schema (E012
otherwise). This adds what ``fmpy.validation.validate_fmu`` checks beyond the schema — unique,
well-formed variable names, a complete ``ModelStructure``, required start values, legal
causality/variability/initial combinations, units, no backslash in a member name — on the
description fmionnx already parsed behind its safety checks (FMPy never opens the archive
itself), and that ``binaries/<platform>/<modelIdentifier>.so`` exists for every interface type
the FMU offers: a folder for Linux holding another library fails only when a run loads it.
"""

from __future__ import annotations

import copy
from pathlib import Path, PurePosixPath
from typing import Any

from fmionnx.core import codes
from fmionnx.core.archive import check_archive, open_zip
from fmionnx.core.types import ComponentInterface
from fmionnx.kinds.base import KindProblem
from fmionnx.kinds.fmu.description import (
    description_key,
    parse_model_description,
    shared_description,
)
from fmionnx.kinds.fmu.exports import (
    PLATFORM_FOLDER,
    describe_missing,
    function_prefix,
    missing_functions,
)
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION, read_fmu_files

#: Binary folders of this machine (FMI 2 and FMI 3 names) and the library suffix in them.
_PLATFORM_FOLDERS = ("linux64", "x86_64-linux")
_LIBRARY_SUFFIX = ".so"
#: Interface types with a model identifier, as named in the ``modelIdentifier…`` facts.
_INTERFACE_NAMES = {"CS": "co-simulation", "ME": "model exchange", "SE": "scheduled execution"}


def validate_fmu_model(path: Path, interface: ComponentInterface) -> tuple[KindProblem, ...]:
    """FMPy's findings (E019) and missing shared libraries (E015), in that order."""
    from fmpy.validation import validate_model_description

    xml_file = Path(path.name) / MODEL_DESCRIPTION
    description = shared_description(
        description_key(path, interface.content_hash),
        lambda: parse_model_description(read_fmu_files(path).model_description, xml_file),
    )
    try:
        found = validate_model_description(
            _without_aliases(description),
            validate_variable_names=True,
            validate_model_structure=True,
        )
    except Exception as exc:  # FMPy's checks assume a sane description; this one is not
        found = [f"the validation stopped: {exc}"]
    problems = [
        KindProblem(codes.INVALID_MODEL, f"FMPy: {_first_line(text)}", "path") for text in found
    ]
    members = _member_names(path)
    problems += [
        KindProblem(
            codes.INVALID_MODEL, f"FMPy: the file path `{name}` contains a backslash", "path"
        )
        for name in members
        if "\\" in name
    ]
    problems += _missing_libraries(interface, members)
    problems += _missing_exports(path, interface)
    return tuple(problems)


def _without_aliases(description: Any) -> Any:
    """A shallow copy without FMI 3 ``<Alias>`` entries, for FMPy's model-structure check.

    FMPy lists each alias as a variable of its own and then expects it among the
    ``<InitialUnknown>`` elements, which name value references: an output with an alias is
    always reported as missing. The shared description itself is never changed.
    """
    variables = description.modelVariables
    if not any(getattr(v, "alias", None) is not None for v in variables):
        return description
    trimmed = copy.copy(description)
    trimmed.modelVariables = [v for v in variables if getattr(v, "alias", None) is None]
    return trimmed


def _first_line(text: str) -> str:
    """FMPy appends a parser's multi-line report to a bad name; its first line says it all."""
    lines = str(text).strip().splitlines()
    return lines[0] if lines else str(text)


def _member_names(path: Path) -> list[str]:
    """Every file of the FMU as a POSIX name relative to its root."""
    if path.is_dir():
        return [p.relative_to(path).as_posix() for p in sorted(path.rglob("*")) if p.is_file()]
    with open_zip(path) as archive:
        check_archive(archive)
        return [info.orig_filename for info in archive.infolist() if not info.is_dir()]


def _missing_exports(path: Path, interface: ComponentInterface) -> list[KindProblem]:
    """E024 per offered interface type whose library lacks a function the standard requires."""
    major = int((interface.fact("fmiVersion") or "0").split(".")[0] or 0)
    problems = []
    for short in ("cs", "me"):
        identifier = interface.fact(f"modelIdentifier{short.upper()}")
        if identifier is None:
            continue
        missing = missing_functions(path, major, short, identifier)
        if missing:
            library = f"binaries/{PLATFORM_FOLDER[major]}/{identifier}.so"
            what = _INTERFACE_NAMES[short.upper()]
            prefix = function_prefix(path, major, identifier)
            text = describe_missing(missing, library, prefix)
            problems.append(KindProblem(codes.MISSING_FUNCTION, f"{text} ({what})", "path"))
    return problems


def _missing_libraries(interface: ComponentInterface, members: list[str]) -> list[KindProblem]:
    """A Linux binary folder must hold the library of each model identifier.

    An FMU without any Linux folder is already E015 from the kind's ``check``.
    """
    files = {PurePosixPath(name.replace("\\", "/")) for name in members}
    folders = [f for f in _PLATFORM_FOLDERS if any(p.parts[:2] == ("binaries", f) for p in files)]
    problems = []
    for short, what in _INTERFACE_NAMES.items():
        identifier = interface.fact(f"modelIdentifier{short}")
        if identifier is None:
            continue
        for folder in folders:
            library = PurePosixPath("binaries", folder, identifier + _LIBRARY_SUFFIX)
            if library not in files:
                problems.append(
                    KindProblem(
                        codes.NO_BINARY,
                        f"`binaries/{folder}/` has no `{library.name}`, the library of the "
                        f"model identifier `{identifier}` ({what})",
                        "path",
                        "re-export the FMU; the binary's name must be the model identifier",
                    )
                )
    return problems
