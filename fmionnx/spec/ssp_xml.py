"""Safe XML parsing and XSD validation of SSP files (``.ssd``, ``.ssv``, ``.ssm``).

SSP files come from other people and other tools, so they are parsed without entity
expansion, DTD loading or network access. Each file is validated against the Modelica
Association schema of *its* version: SSP 1.0 and 2.0 (files written by OMSimulator and
easySSP today say ``version="2.0"`` but keep the ``SSP1`` namespaces). The schemas come from
the ``pyssp-standard`` package, which ships both; fmpy ships only 1.0.
"""

from __future__ import annotations

import functools
import importlib.resources
from pathlib import Path
from typing import Any

from lxml import etree

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import read_regular
from fmionnx.core.resources import SSP_XML_BYTES
from fmionnx.core.sourcetext import edited_text

SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC_NS = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
SSM_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterMapping"
SSB_NS = "http://ssp-standard.org/SSP1/SystemStructureSignalDictionary"
NS = {"ssd": SSD_NS, "ssc": SSC_NS, "ssv": SSV_NS, "ssm": SSM_NS, "ssb": SSB_NS}

#: Schema file of each SSP file kind (same names in both versions' folders).
_SCHEMA_FILES = {
    "ssd": "SystemStructureDescription.xsd",
    "ssv": "SystemStructureParameterValues.xsd",
    "ssm": "SystemStructureParameterMapping.xsd",
}
#: Folder of each supported major version inside ``pyssp_standard/resources``.
_VERSION_FOLDERS = {"1": "", "2": "ssp2/"}


def tag(ns: str, name: str) -> str:
    """Clark notation ``{namespace}name`` for lxml lookups."""
    return f"{{{NS[ns]}}}{name}"


def short(text: str) -> str:
    """Replace namespace URIs in validator messages by their usual prefixes."""
    for prefix, uri in NS.items():
        text = text.replace(f"{{{uri}}}", f"{prefix}:")
    return text


def _parser() -> Any:
    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        load_dtd=False,
        dtd_validation=False,
        huge_tree=False,
        remove_blank_text=False,
    )


def parse_xml(path: Path, bag: DiagnosticBag) -> Any:
    """Parse an SSP XML file safely; None (and E010/E001 diagnostics) on failure.

    A file being edited (:func:`fmionnx.core.sourcetext.editing`) is parsed from the editor's
    text.
    """
    edited = edited_text(path)
    data = None if edited is None else edited.encode("utf-8", "surrogatepass")
    try:
        size = path.stat().st_size if data is None else len(data)
    except OSError:
        bag.emit(codes.FILE_NOT_FOUND, f"`{path.name}` does not exist", Span(path))
        return None
    # Checked before parsing: SSDs of large systems are a few MB, and lxml's tree of a huge
    # file takes several times its size in memory.
    try:
        largest = SSP_XML_BYTES.value()
    except ModelError as exc:  # a malformed FMIONNX_MAX_SSP_XML_BYTES
        bag.emit(exc.code, str(exc), Span(path), hint=exc.hint)
        return None
    if size > largest:
        bag.emit(
            codes.RESOURCE_LIMIT,
            f"`{path.name}` is {size} bytes, larger than {largest}",
            Span(path),
            hint=SSP_XML_BYTES.hint(),
        )
        return None
    if data is None:
        try:  # only a regular file: a FIFO or a device would never end (E011)
            data = read_regular(path, SSP_XML_BYTES, f"`{path.name}`")
        except ModelError as exc:
            bag.emit(exc.code, str(exc), Span(path), hint=exc.hint)
            return None
        except OSError as exc:
            bag.emit(codes.FILE_NOT_FOUND, f"cannot read `{path.name}`: {exc}", Span(path))
            return None
    try:
        tree = etree.fromstring(data, _parser(), base_url=str(path)).getroottree()
    except etree.XMLSyntaxError as exc:
        line, col = exc.position if exc.position else (1, 0)
        bag.emit(
            codes.SYNTAX, f"`{path.name}` is not well-formed XML: {exc.msg}", Span(path, line, col)
        )
        return None
    except OSError as exc:
        bag.emit(codes.FILE_NOT_FOUND, f"cannot read `{path.name}`: {exc}", Span(path))
        return None
    if tree.docinfo.doctype or tree.docinfo.internalDTD is not None:
        # libxml2 expands an internal DTD's entities even without resolve_entities (only
        # external ones are left alone): a file could say one thing to fmionnx and another
        # to a tool that reads it without them. No SSP file needs a DTD; refused, as a model
        # description's is (fmionnx.core.xmlsafe).
        bag.emit(
            codes.UNSAFE_ARCHIVE,
            f"`{path.name}` declares a DTD (<!DOCTYPE ...>); SSP files must not",
            Span(path, 1, 1),
            hint="DTDs define entities that expand without bound or read local files; "
            "fmionnx refuses them",
        )
        return None
    return tree


@functools.cache
def schema(kind: str, major: str) -> Any:
    """The compiled XSD of an SSP file kind (``ssd``/``ssv``/``ssm``) and major version."""
    base = importlib.resources.files("pyssp_standard") / "resources"
    resource = base / (_VERSION_FOLDERS[major] + _SCHEMA_FILES[kind])
    with importlib.resources.as_file(resource) as file:
        document = etree.parse(str(file), _parser())
        return etree.XMLSchema(document)


def major_version(root: Any, path: Path, bag: DiagnosticBag) -> str | None:
    """The major SSP version (``"1"``/``"2"``) of a file's root, or None with E070/E071.

    The attribute is checked before the schema (which schema applies depends on it), so its
    absence is reported here, as the schema violation it is (E070), not as an unsupported
    version.
    """
    version = root.get("version")
    if version is None:
        bag.emit(
            codes.SSP_SCHEMA,
            f"`{path.name}`: the required `version` attribute of `{short(root.tag)}` is missing",
            Span(path, root.sourceline or 1),
            hint='add version="1.0" or version="2.0", the SSP version the file follows',
        )
        return None
    version = str(version)
    major = version.split(".", 1)[0]
    if major not in _VERSION_FOLDERS:
        bag.emit(
            codes.SSP_UNSUPPORTED,
            f"SSP version `{version}` of `{path.name}` is not supported",
            Span(path, root.sourceline or 1),
            hint="fmionnx reads SSP 1.0 and 2.0 files",
        )
        return None
    return major


def validate(tree: Any, kind: str, path: Path, bag: DiagnosticBag) -> bool:
    """Validate a parsed file against its version's XSD; each error becomes E070."""
    root = tree.getroot()
    major = major_version(root, path, bag)
    return major is not None and _valid(tree, kind, major, path, bag)


def validate_inline(element: Any, kind: str, path: Path, bag: DiagnosticBag) -> bool:
    """Validate a parameter set (``ssv``) or mapping (``ssm``) written inside the SSD ``path``
    against its own XSD; each error becomes E070 at its line.

    The SSD's schema leaves their content to any namespace, unchecked (``xs:any``, lax), so
    without this a name, source or factor missing or malformed inside an SSD reached the
    reader unchecked, where the same in a ``.ssv`` or ``.ssm`` file is refused. An element
    without its own ``version`` is checked by the SSD's.
    """
    owner = element.getroottree().getroot()
    major = major_version(element if element.get("version") else owner, path, bag)
    return major is not None and _valid(element, kind, major, path, bag)


def _valid(node: Any, kind: str, major: str, path: Path, bag: DiagnosticBag) -> bool:
    xsd = schema(kind, major)
    if xsd.validate(node):
        return True
    for entry in xsd.error_log:
        bag.emit(
            codes.SSP_SCHEMA,
            f"{path.name} does not follow the SSP {major}.0 schema: {short(entry.message)}",
            Span(path, entry.line, 0),
            hint="fix the file in the tool that wrote it, or by hand",
        )
    return False
