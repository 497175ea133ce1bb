"""One parsed model description per FMU and process, shared by compiling and running.

Compiling parses ``modelDescription.xml`` with fmpy (schema-validated) to build the interface;
instantiating needs it again (GUID, model identifier, model-exchange sizes), and so does the
naming of a single FMU's result columns. A system may use one FMU many times, and parsing a
large model description costs far more than a lookup, so the parsed fmpy ``ModelDescription``
is kept per process, keyed by the FMU's file identity (resolved path, modification time, size)
and content hash. Whoever holds it only reads it.

The key of a compiled component uses the hash its interface carries, so a run in the process
that compiled the system parses nothing more; a changed file has another identity and is parsed
again, from the bytes the caller reads (the unpacked copy the runner will load, for instance).
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Component
from fmionnx.core.xmlsafe import parse_safely
from fmionnx.kinds.cache import BoundedCache, file_identity
from fmionnx.kinds.fmu.files import MODEL_DESCRIPTION, identity_file

#: How many parsed descriptions to keep; more than the distinct FMUs of any real system.
MAX_ENTRIES = 64

#: How many schema problems to quote in an error message.
_MAX_PROBLEMS = 3

#: (resolved path, mtime in ns, size, content hash) of the FMU.
DescriptionKey = tuple[str, int, int, str]

_CACHE: BoundedCache[DescriptionKey, Any] = BoundedCache(MAX_ENTRIES)


def description_key(path: Path, content_hash: str) -> DescriptionKey:
    """The cache key of the FMU at ``path`` (archive or unpacked folder) with that hash."""
    return (*file_identity(identity_file(path)), content_hash)


def shared_description(key: DescriptionKey, parse: Callable[[], Any]) -> Any:
    """The parsed description for ``key``, calling ``parse`` only on a miss."""
    return _CACHE.get_or_load(key, parse)


def component_description(component: Component, read: Callable[[], bytes]) -> Any:
    """The parsed model description of a compiled FMU component.

    ``read`` returns the model description's bytes and is called only on a miss; they pass
    the same safety check as at compile time before fmpy sees them.
    """
    xml_file = Path(component.path.name) / MODEL_DESCRIPTION

    def parse() -> Any:
        data = read()
        parse_safely(data, str(xml_file))
        return parse_model_description(data, xml_file)

    key = description_key(component.path, component.interface.content_hash)
    return shared_description(key, parse)


def clear_descriptions() -> None:
    """Forget every parsed description (tests, long-running processes)."""
    _CACHE.clear()


def parse_model_description(data: bytes, xml_file: Path) -> Any:
    """fmpy's reading of exactly ``data``, bytes that passed the safety check.

    fmpy reads a model description from a zip; an in-memory zip holding only these bytes
    keeps it from re-reading the FMU or parsing any other file.

    Raises ModelError E012 when the description does not conform to the FMI schema or fmpy
    cannot read it.
    """
    from fmpy.model_description import ValidationError, read_model_description

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as archive:
        archive.writestr(MODEL_DESCRIPTION, data)
    buffer.seek(0)
    try:
        return read_model_description(buffer, validate=True)
    except ValidationError as exc:
        problems = "; ".join(str(p) for p in exc.problems[:_MAX_PROBLEMS])
        more = len(exc.problems) - _MAX_PROBLEMS
        tail = f" (and {more} more)" if more > 0 else ""
        msg = f"`{xml_file}` does not conform to the FMI schema: {problems}{tail}"
        raise ModelError(
            codes.BAD_MODEL, msg, hint="`fmpy validate <fmu>` lists every problem"
        ) from None
    except Exception as exc:  # fmpy raises bare Exception for semantic errors
        from fmionnx.kinds.fmu.structure import structure_problem

        problem = structure_problem(parse_safely(data, str(xml_file))) or exc
        msg = f"`{xml_file}` cannot be read: {problem}"
        raise ModelError(codes.BAD_MODEL, msg) from None
