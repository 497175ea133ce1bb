"""Check model XML before any XML library with looser defaults sees it.

FMUs come from other people. fmpy parses ``modelDescription.xml`` with lxml's default parser,
whose entity handling depends on the lxml version. A model description never needs a DTD, so
fmionnx parses the bytes first with a parser that resolves no entities, loads no DTD and
touches no network, and refuses any document that declares a DTD at all (which rules out
external entities and entity-expansion bombs for every later parser).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fmionnx.core import codes
from fmionnx.core.errors import ModelError

if TYPE_CHECKING:  # lxml loads when XML is parsed: reading a compiled system parses none
    from lxml import etree

_SAFE_PARSER_OPTIONS = {
    "resolve_entities": False,
    "no_network": True,
    "load_dtd": False,
    "dtd_validation": False,
    "huge_tree": False,
}


def parse_safely(data: bytes, label: str) -> etree._Element:
    """Parse ``data`` (the XML file called ``label`` in messages); return the root element.

    Raises ModelError E012 for XML that is not well-formed, and E017 for a document that
    declares a DTD (entities are never expanded, external ones never fetched).
    """
    from lxml import etree

    parser = etree.XMLParser(**_SAFE_PARSER_OPTIONS)
    try:
        root = etree.fromstring(data, parser)
    except etree.XMLSyntaxError as exc:
        line = f" (line {exc.lineno})" if exc.lineno else ""
        msg = f"`{label}` is not well-formed XML{line}: {exc.msg}"
        raise ModelError(codes.BAD_MODEL, msg) from None
    tree = root.getroottree()
    if tree.docinfo.doctype or tree.docinfo.internalDTD is not None:
        msg = f"`{label}` declares a DTD (<!DOCTYPE ...>); model files must not"
        raise ModelError(
            codes.UNSAFE_ARCHIVE,
            msg,
            hint="DTDs can define entities that read local files or expand without bound; "
            "fmionnx refuses them",
        )
    return root
