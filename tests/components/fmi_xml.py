"""Tiny writers of FMI model descriptions and FMU archives for reader tests."""

from __future__ import annotations

import stat
import zipfile
from pathlib import Path


def scalar(
    name: str,
    vr: int,
    causality: str,
    fmi_type: str = "Real",
    type_attrs: str = "",
    variability: str = "",
) -> str:
    """One FMI 2 ``<ScalarVariable>``; inputs and parameters get a start value."""
    start = ' start="0"' if causality in ("input", "parameter") else ""
    if fmi_type == "Boolean" and start:
        start = ' start="false"'
    if fmi_type == "String" and start:
        start = ' start=""'
    var = f' variability="{variability}"' if variability else ""
    if causality == "parameter" and not variability:
        var = ' variability="fixed"'
    if fmi_type in ("Integer", "Boolean", "String", "Enumeration") and causality != "parameter":
        var = var or ' variability="discrete"'
    return (
        f'<ScalarVariable name="{name}" valueReference="{vr}" causality="{causality}"{var}>'
        f"<{fmi_type}{start} {type_attrs}/></ScalarVariable>"
    )


def fmi2(variables: list[str], structure: str = "", extra: str = "") -> str:
    """A complete FMI 2.0 model description (co-simulation) around ``variables``."""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<fmiModelDescription fmiVersion="2.0" modelName="T" guid="{t}">\n'
        '  <CoSimulation modelIdentifier="T"/>\n'
        f"  {extra}\n"
        "  <ModelVariables>\n    " + "\n    ".join(variables) + "\n  </ModelVariables>\n"
        f"  <ModelStructure>{structure}</ModelStructure>\n"
        "</fmiModelDescription>\n"
    )


def fmi3(variables: list[str], structure: str = "", extra: str = "") -> str:
    """A complete FMI 3.0 model description (co-simulation) with a ``time`` variable."""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        '<fmiModelDescription fmiVersion="3.0" modelName="T" instantiationToken="{t}">\n'
        '  <CoSimulation modelIdentifier="T"/>\n'
        f"  {extra}\n"
        "  <ModelVariables>\n"
        '    <Float64 name="time" valueReference="0" causality="independent" '
        'variability="continuous"/>\n    ' + "\n    ".join(variables) + "\n  </ModelVariables>\n"
        f"  <ModelStructure>{structure}</ModelStructure>\n"
        "</fmiModelDescription>\n"
    )


def fmu_folder(root: Path, name: str, model_description: str) -> Path:
    """An unpacked FMU folder holding only ``modelDescription.xml``."""
    folder = root / name
    folder.mkdir()
    (folder / "modelDescription.xml").write_text(model_description, encoding="utf-8")
    return folder


def fmu_zip(path: Path, members: dict[str, bytes], links: tuple[str, ...] = ()) -> Path:
    """A zip with ``members`` (deflated); names in ``links`` are stored as symbolic links."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, data in members.items():
            info = zipfile.ZipInfo(name)
            info.compress_type = zipfile.ZIP_DEFLATED
            mode = (stat.S_IFLNK | 0o777) if name in links else (stat.S_IFREG | 0o644)
            info.external_attr = mode << 16
            archive.writestr(info, data)
    return path
