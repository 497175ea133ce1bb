"""Why a ``<ModelStructure>`` fmpy could not read names no variable, with the line.

fmpy resolves the structure's references while it reads a model description and fails with
Python's own words (``list index out of range`` for an FMI 2 ``index="99"`` of a model of nine
variables, a bare ``KeyError`` for an FMI 3 value reference no variable has). Looked at only
after fmpy failed, so a good description pays nothing for it.
"""

from __future__ import annotations

from typing import Any

#: FMI 2: ``<Unknown index=".." dependencies="..">`` refer to ScalarVariables by 1-based index.
_FMI2_VARIABLES = "ModelVariables/ScalarVariable"
_FMI2_UNKNOWNS = "ModelStructure/*/Unknown"


def structure_problem(root: Any) -> str | None:
    """The first reference of ``root``'s ``<ModelStructure>`` to no variable, as a phrase with
    its line, or None when every reference names one."""
    if root.get("fmiVersion", "").startswith("2"):
        return _fmi2_problem(root)
    return _fmi3_problem(root)


def _fmi2_problem(root: Any) -> str | None:
    count = len(root.findall(_FMI2_VARIABLES))
    for unknown in root.iterfind(_FMI2_UNKNOWNS):
        for attribute in ("index", "dependencies"):
            for word in (unknown.get(attribute) or "").split():
                if not (word.isdigit() and 1 <= int(word) <= count):
                    return (
                        f"line {unknown.sourceline}: <{unknown.getparent().tag}> "
                        f'<Unknown {attribute}="{unknown.get(attribute)}"> names no variable: '
                        f"an index is a whole number from 1 to the number of ScalarVariables "
                        f"({count})"
                    )
    return None


def _fmi3_problem(root: Any) -> str | None:
    variables = root.find("ModelVariables")
    known = {
        element.get("valueReference")
        for element in (variables if variables is not None else ())
        if isinstance(element.tag, str)
    }
    structure = root.find("ModelStructure")
    for element in structure if structure is not None else ():
        if not isinstance(element.tag, str):  # a comment
            continue
        for attribute in ("valueReference", "dependencies"):
            for word in (element.get(attribute) or "").split():
                if word not in known:
                    return (
                        f"line {element.sourceline}: <{element.tag} {attribute}="
                        f'"{element.get(attribute)}"> names no variable: no variable has the '
                        f"value reference {word}"
                    )
    return None
