"""YAML front end: bytes -> plain data with positions -> validated :class:`SystemSpec`.

ruamel.yaml's round-trip loader keeps line/column marks on every mapping and sequence; we
convert its nodes to plain Python values while recording positions in a
:class:`~fmionnx.spec.sourcemap.SourceMap`. The loader constructs only plain data (maps,
lists, scalars): any explicit tag is rejected, so no object is ever built from the file.
"""

from __future__ import annotations

import datetime as dt
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from fmionnx.core import codes
from fmionnx.core.codes import ErrorCode
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.sourcetext import edited_text
from fmionnx.spec.limits import MAX_DOCUMENT_BYTES, check_limits, check_size
from fmionnx.spec.model import SystemSpec
from fmionnx.spec.pydantic_errors import report_validation_error
from fmionnx.spec.sourcemap import KeyPath, SourceMap
from fmionnx.spec.yaml_hints import flow_index_hint

if TYPE_CHECKING:
    from ruamel.yaml.comments import CommentedMap, CommentedSeq
    from ruamel.yaml.error import MarkedYAMLError

#: Kept for callers of the former name; the limits live in :mod:`fmionnx.spec.limits`.
MAX_SYSTEM_FILE_BYTES = MAX_DOCUMENT_BYTES


@dataclass(frozen=True)
class LoadedSpec:
    """A front end's result: the spec (None when unusable), and where everything is."""

    spec: SystemSpec | None
    sources: SourceMap
    path: Path


class _TagError(Exception):
    def __init__(self, path: KeyPath, tag: str) -> None:
        self.path = path
        self.tag = tag


class _StructureError(Exception):
    """YAML that is valid but not what a system file may hold (a merge key, a cycle)."""

    def __init__(self, path: KeyPath, message: str, hint: str) -> None:
        self.path = path
        self.message = message
        self.hint = hint


def read_text(path: Path, bag: DiagnosticBag) -> str | None:
    """Read a UTF-8 text file, reporting missing files, directories and bad encodings.

    A file being edited (:func:`fmionnx.core.sourcetext.editing`) reads as the editor's text,
    within the same size limit.
    """
    span = Span(path)
    edited = edited_text(path)
    if edited is not None:
        size = len(edited.encode("utf-8", "surrogatepass"))
        return edited if check_size(size, path, bag) else None
    if not path.exists():
        bag.emit(codes.FILE_NOT_FOUND, f"system file `{path}` does not exist", span)
        return None
    if not path.is_file():
        bag.emit(
            codes.NOT_A_FILE, f"`{path}` is a directory or special file, not a system file", span
        )
        return None
    try:
        # The size is checked before reading, so a huge file is never loaded into memory.
        if not check_size(path.stat().st_size, path, bag):
            return None
        with path.open("rb") as stream:
            data = stream.read(MAX_DOCUMENT_BYTES + 1)
    except OSError as exc:
        bag.emit(codes.FILE_NOT_FOUND, f"cannot read `{path}`: {exc.strerror}", span)
        return None
    if not check_size(len(data), path, bag):
        return None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        col = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        bag.emit(
            codes.ENCODING,
            f"the file is not UTF-8 text (byte 0x{data[exc.start]:02x})",
            Span(path, line, col),
            hint="save the file as UTF-8",
        )
        return None


def is_study_document(data: object) -> bool:
    """True for a parsed YAML document that is a study: it names a ``system:`` to vary and
    lists no ``components:`` of its own (a system file does the opposite)."""
    return isinstance(data, dict) and "system" in data and "components" not in data


def is_study_text(text: str, path: Path) -> bool:
    """Whether ``text`` is a study document (:func:`is_study_document`), for choosing how to
    check a file before it is loaded for good.

    Only the top-level keys matter, so this reads the text with ruamel's C-based safe loader
    (about 1 ms for a system file) rather than the round-trip parser that records every
    position (about 9 ms), which the file's real load runs anyway. Within the same resource
    limits; a text that does not load is not a study here (its load reports why).
    """
    if not check_limits(text, path, DiagnosticBag()):
        return False
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        data = YAML(typ="safe").load(text)
    except (YAMLError, TypeError, ValueError):
        return False
    return is_study_document(data)


def load_yaml_system(path: Path, bag: DiagnosticBag) -> LoadedSpec:
    """Load and validate a YAML system file; every problem goes into ``bag``."""
    sources = SourceMap(path)
    text = read_text(path, bag)
    if text is None:
        return LoadedSpec(None, sources, path)
    data = parse_yaml(text, path, sources, bag)
    if data is None:
        return LoadedSpec(None, sources, path)
    if not isinstance(data, dict):
        bag.emit(
            codes.INVALID_VALUE,
            "a system file must be a mapping with keys `fmionnx`, `name`, `components` ...",
            Span(path, 1, 1),
            hint="start the file with `fmionnx: 1`",
        )
        return LoadedSpec(None, sources, path)
    if is_study_document(data):
        bag.emit(
            codes.INVALID_VALUE,
            f"`{path.name}` is a study file (it names a `system:` to vary), not a system file",
            Span(path, 1, 1),
            hint=f"run its cases with `fmionnx sweep {path.name} --out DIR`; "
            f"`fmionnx validate {path.name}` checks it",
        )
        return LoadedSpec(None, sources, path)
    try:
        spec = SystemSpec.model_validate(data)
    except ValidationError as exc:
        report_validation_error(exc, data, sources, bag)
        return LoadedSpec(None, sources, path)
    return LoadedSpec(spec, sources, path)


def parse_yaml(text: str, path: Path, sources: SourceMap, bag: DiagnosticBag) -> Any:
    """Parse YAML text to plain data, recording positions; None (and a diagnostic) on error.

    The resource limits (:mod:`fmionnx.spec.limits`) are checked first, on the event stream,
    so an alias bomb or a deeply nested document never reaches the composer.
    """
    if not check_limits(text, path, bag):
        return None
    # ruamel is imported here, not at the top: a lone model (`fmionnx run model.fmu`) is
    # compiled through the spec types of this module but reads no YAML.
    from ruamel.yaml import YAML
    from ruamel.yaml.constructor import DuplicateKeyError
    from ruamel.yaml.error import MarkedYAMLError, ReusedAnchorWarning, YAMLError

    yaml = YAML(typ="rt")
    yaml.allow_duplicate_keys = False
    try:
        with warnings.catch_warnings():
            # YAML lets a later anchor of the same name replace an earlier one; ruamel warns
            # about it on stderr, with its own source line: not something to show a user.
            warnings.simplefilter("ignore", ReusedAnchorWarning)
            node = yaml.load(text)
    except TypeError:  # ruamel hashes every key: a mapping or list as a key cannot be
        bag.emit(
            codes.SYNTAX,
            "invalid YAML: a mapping key is itself a mapping or a list",
            Span(path, 1, 1),
            hint="keys of a system file are plain names",
        )
        return None
    except (AttributeError, ValueError, KeyError, IndexError) as exc:
        # ruamel builds some nodes without checking them first and fails inside its
        # constructor: a tag on a value it does not fit (`!!set fmionnx: 1`), a date that
        # does not exist (`2020-02-30`, read as a timestamp).
        tag = _first_tag(text, path)
        if tag is not None:
            bag.emit(
                codes.SYNTAX,
                "invalid YAML: a tag does not fit the value it is put on",
                tag,
                hint="system and study files hold plain maps, lists, strings and numbers, no tags",
            )
        else:
            bag.emit(
                codes.SYNTAX,
                f"invalid YAML: a value the YAML reader cannot build: {exc}",
                Span(path, 1, 1),
                hint='quote a value meant as text (`"2020-02-30"`): YAML reads some as dates',
            )
        return None
    except DuplicateKeyError as exc:
        _report_marked(exc, path, bag, codes.DUPLICATE_KEY)
        return None
    except MarkedYAMLError as exc:
        _report_marked(exc, path, bag, codes.SYNTAX, text=text)
        return None
    except YAMLError as exc:
        bag.emit(codes.SYNTAX, f"invalid YAML: {exc}", Span(path, 1, 1))
        return None
    if node is None:
        bag.emit(
            codes.MISSING_KEY,
            "the system file is empty",
            Span(path, 1, 1),
            hint="start with `fmionnx: 1`",
        )
        return None
    sources.record((), Span(path, 1, 1))
    try:
        return _plain(node, (), sources)
    except _TagError as exc:
        bag.emit(
            codes.INVALID_VALUE,
            f"YAML tag `{exc.tag}` is not allowed in a system file",
            sources.value(exc.path),
            hint="system files hold plain maps, lists, strings and numbers",
        )
        return None
    except _StructureError as exc:
        bag.emit(codes.INVALID_VALUE, exc.message, sources.value(exc.path), hint=exc.hint)
        return None


def _first_tag(text: str, path: Path) -> Span | None:
    """Where the document's first tag (``!name``, ``!!name``) starts; None without one."""
    import re

    found = re.search(r"(?:^|(?<=[\s\[{,:-]))!", text, flags=re.MULTILINE)
    if found is None:
        return None
    line = text.count("\n", 0, found.start()) + 1
    column = found.start() - (text.rfind("\n", 0, found.start()) + 1) + 1
    return Span(path, line, column)


def _report_marked(
    exc: MarkedYAMLError, path: Path, bag: DiagnosticBag, code: ErrorCode, *, text: str = ""
) -> None:
    mark = exc.problem_mark or exc.context_mark
    if exc.problem and "<stream end>" in exc.problem and exc.context_mark is not None:
        # "expected ']' but got end of file": the opening bracket is the useful position.
        mark = exc.context_mark
    span = Span(path, mark.line + 1, mark.column + 1) if mark is not None else Span(path, 1, 1)
    problem = exc.problem or "invalid YAML"
    if code is codes.DUPLICATE_KEY:
        message = problem.split(" with value")[0]
        problem = message.replace("found duplicate key", "duplicate key")
        bag.emit(code, problem, span, hint="each key may appear once in a mapping")
        return
    context = f" ({exc.context})" if exc.context else ""
    hint = None
    if mark is not None and exc.problem is not None:
        hint = flow_index_hint(text, mark.line, mark.column, exc.problem)
    indentation = _indentation_problem(exc)
    if indentation is not None:
        message, hint = indentation
        bag.emit(code, message, span, hint=hint)
        return
    bag.emit(code, f"invalid YAML: {problem}{context}", span, hint=hint)


def _indentation_problem(exc: MarkedYAMLError) -> tuple[str, str] | None:
    """Message and hint for YAML's "expected <block end>, but found ...": a line that does
    not line up with the block (mapping or list) it is in, said in a user's words."""
    if not (exc.problem or "").startswith("expected <block end>") or exc.context_mark is None:
        return None
    column = exc.context_mark.column + 1
    if "sequence" in (exc.context or ""):
        return (
            f"invalid YAML: this line does not line up with the list it is in (its items "
            f"start with `-` in column {column})",
            "give every item of a list the same indentation",
        )
    return (
        f"invalid YAML: this line does not line up with the mapping it is in (its keys start "
        f"in column {column})",
        f"indent the keys of one mapping alike (here: column {column}); to nest this line "
        "under the key above, end that key's line with `:` and no value",
    )


def _plain(
    node: Any, path: KeyPath, sources: SourceMap, inside: frozenset[int] = frozenset()
) -> Any:
    """Convert ruamel nodes to plain dict/list/scalars and record spans (recursive).

    ``inside``: the containers being converted, so that an alias to one of them (``&a [*a]``,
    a structure that contains itself) is refused instead of recursing for ever.
    """
    from ruamel.yaml.comments import CommentedMap, CommentedSeq  # loaded by parse_yaml

    file = sources.file
    if isinstance(node, (CommentedMap, CommentedSeq)):
        if id(node) in inside:
            raise _StructureError(
                path,
                "a YAML alias refers to a mapping or list that contains it (a structure that "
                "contains itself)",
                "an alias (`*name`) may only repeat a node defined before and outside it",
            )
        inside = inside | {id(node)}
    if isinstance(node, CommentedMap):
        _reject_tag(node, path)
        if getattr(node, "merge", None):
            raise _StructureError(
                path,
                "YAML merge keys (`<<`) are not allowed in a system file",
                "write the keys out, or repeat a whole value with an alias (`*name`)",
            )
        result: dict[str, Any] = {}
        for key in node:
            key_line, key_col = node.lc.key(key)
            value_line, value_col = node.lc.value(key)
            child = (*path, str(key))
            sources.record(
                child,
                Span(file, value_line + 1, value_col + 1),
                Span(file, key_line + 1, key_col + 1),
            )
            result[str(key)] = _plain(node[key], child, sources, inside)
        return result
    if isinstance(node, CommentedSeq):
        _reject_tag(node, path)
        items: list[Any] = []
        for index, item in enumerate(node):
            line, col = node.lc.item(index)
            child = (*path, index)
            sources.record(child, Span(file, line + 1, col + 1))
            items.append(_plain(item, child, sources, inside))
        return items
    if isinstance(node, bool) or node is None:
        return node
    if isinstance(node, int):
        return int(node)
    if isinstance(node, float):
        return float(node)
    if isinstance(node, str) and type(node).__name__ in {
        "str",
        "ScalarString",
        "LiteralScalarString",
        "FoldedScalarString",
        "SingleQuotedScalarString",
        "DoubleQuotedScalarString",
        "PlainScalarString",
    }:
        return str(node)
    if isinstance(node, dt.date):
        return node.isoformat()
    tag = getattr(getattr(node, "tag", None), "value", None) or type(node).__name__
    raise _TagError(path, str(tag))


def _reject_tag(node: CommentedMap | CommentedSeq, path: KeyPath) -> None:
    tag = getattr(node, "tag", None)
    value = getattr(tag, "value", None)
    if value:
        raise _TagError(path, str(value))
