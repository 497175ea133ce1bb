"""Completion from the real model interfaces and the file formats.

What is offered depends on where the cursor is (:mod:`fmionnx.lsp.yamlcontext`):

* keys of the format at that place (a component entry's keys by its ``kind``), and fixed
  values (``kind:``, ``interface:``, QoS names ...);
* component names, and after ``component.`` its ports with causality, type, shape and unit:
  outputs left of ``->`` in a connection (and in ``from:``), inputs right of it
  (and in ``to:``), any port in ``record``, ``plots`` and checks; a port whose name is no
  dotted word is inserted as an endpoint writes it, quoted (``p."input.1"``), and in a check
  between backticks (`` `p."input.1"` ``);
* parameter names under ``parameters:`` and in a study's targets, port names and units under
  an ONNX entry's ``units:``, units after any ``unit:`` of an entry;
* ROS 2: message types, the fields of the type given, component names as node keys;
* the checks language: its functions, signals, ``component.site.NAME`` and
  ``component.expected_path``;
* model files under ``path:`` and the study's ``system:``.
"""

from __future__ import annotations

import contextlib
import enum
import re
from collections.abc import Iterable, Sequence
from typing import Any

from lsprotocol import types
from pydantic import BaseModel

from fmionnx.compile.checks import FUNCTIONS
from fmionnx.compile.endpoints import endpoint_text
from fmionnx.compile.expected_path import EXPECTED_PATH, expected_path_file
from fmionnx.compile.plots import MAP_REFERENCE
from fmionnx.compile.typecheck import SOURCE_CAUSALITIES, TARGET_CAUSALITIES
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Causality, Port, PortRef
from fmionnx.core.units import BUILTIN_UNITS, Unit
from fmionnx.kinds.base import MAP, SITES, SiteSource
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.lsp.analysis import DocumentKind
from fmionnx.lsp.outline import ComponentOutline, Outline
from fmionnx.lsp.references import components_of
from fmionnx.lsp.schema import keys_at, takes_mappings_only, values_at
from fmionnx.lsp.yamlcontext import ITEM, Cursor, cursor_at, name_before, split_typed_port
from fmionnx.spec.model import SystemSpec
from fmionnx.spec.study import StudySpec

_K = types.CompletionItemKind
#: Characters of a name (a key, a component, a port) an item replaces after the cursor.
_WORD_CHARACTERS = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_$-"
#: A name the checks language reads without backticks (its NAME token, less the index).
_CHECK_NAME = re.compile(r"[A-Za-z_$][\w$]*(?:\.[A-Za-z_$][\w$]*)*")
#: Text that cannot be inside a quoted port name being completed: its end is not after it.
_NOT_IN_QUOTES = re.compile(r"->|[,\[\]{}`]")
#: Targets of a study that are run settings, not parameters (docs/sweep.md).
_RUN_TARGETS = {
    "run.stop": "stop time of each case",
    "run.output_interval": "seconds between two rows of results",
}
#: `isolate:` values of a study besides component names.
_ISOLATE = {"fmus": "every FMU", "all": "every component", "none": "nothing isolated"}


def port_detail(port: Port) -> str:
    """``output float64[1,3] px``: causality, element type, shape and unit."""
    shape = "" if port.is_scalar else port.shape_text()
    unit = f" {port.unit}" if port.unit else ""
    return f"{port.causality.value} {port.dtype.value}{shape}{unit}"


def unit_detail(unit: Unit) -> str:
    """What a unit is in SI: ``0.277778 m*s^-1`` (km/h), ``K + 273.15`` (degC)."""
    scale = "" if unit.factor == 1.0 else f"{unit.factor:g} "
    shift = "" if unit.offset == 0.0 else f" + {unit.offset:g}"
    return f"{scale}{unit.dimension()}{shift}"


def complete(
    text: str, line: int, column: int, kind: DocumentKind, outline: Outline | None
) -> list[types.CompletionItem]:
    """The completion items at 0-based ``line``/``column`` of ``text``."""
    if kind not in (DocumentKind.SYSTEM, DocumentKind.STUDY):
        return []
    cursor = cursor_at(text, line, column)
    root: type[BaseModel] = StudySpec if kind is DocumentKind.STUDY else SystemSpec
    data = outline.data if outline is not None else None
    here = _Here(cursor, text, line, column, outline, data)
    items = _study(here) if kind is DocumentKind.STUDY else _system(here)
    if items is None:
        items = _schema(here, root)
    return items


class _Here:
    """The request: where the cursor is and what the file is known to hold."""

    def __init__(
        self, cursor: Cursor, text: str, line: int, column: int, outline: Outline | None, data: Any
    ) -> None:
        self.cursor = cursor
        self.path = cursor.path
        self.line = line
        self.column = column
        self.outline = outline
        self.data = data
        self.components = components_of(outline)
        lines = text.split("\n")
        rest = lines[line][column:] if line < len(lines) else ""
        #: The line before and after the cursor.
        self.before = lines[line][:column] if line < len(lines) else ""
        self.rest = rest
        #: The rest of the word the cursor is in: an item replaces it too (`kind: |onnx`).
        self.word_after = len(rest) - len(rest.lstrip(_WORD_CHARACTERS)) if rest else 0
        self.dot_after = rest[self.word_after : self.word_after + 1] == "."

    def edit_range(self, typed: str, after: int | None = None) -> types.Range:
        """What an item replaces: the ``typed`` characters before the cursor and the rest of
        the word after it (``after`` characters, when given)."""
        after = self.word_after if after is None else after
        return types.Range(
            types.Position(line=self.line, character=max(0, self.column - len(typed))),
            types.Position(line=self.line, character=self.column + after),
        )

    def port_after(self, partial: str) -> int:
        """How much after the cursor a port replaces: the rest of a quoted name (to its
        closing quote) when the cursor is in one, else the rest of the word.

        Without it, a port picked inside ``p."1|2"`` left the old name's tail behind.
        """
        rest = self.rest
        if partial.startswith('"'):
            closing = rest.find('"')
        elif not partial and rest.startswith('"'):
            closing = rest.find('"', 1)
        else:
            return self.word_after
        if closing < 0 or _NOT_IN_QUOTES.search(rest[:closing]):
            return self.word_after
        return closing + 1

    def item(
        self,
        label: str,
        typed: str,
        kind: types.CompletionItemKind,
        detail: str = "",
        documentation: str = "",
        order: int = 0,
        insert: str | None = None,
        after: int | None = None,
        filter_text: str | None = None,
    ) -> types.CompletionItem:
        """One item replacing ``typed`` (and ``after`` characters after the cursor, by default
        the rest of the word) with ``insert`` (default: the label)."""
        return types.CompletionItem(
            label=label,
            kind=kind,
            detail=detail or None,
            documentation=types.MarkupContent(types.MarkupKind.Markdown, documentation)
            if documentation
            else None,
            sort_text=f"{order:02d}{label}",
            filter_text=filter_text or label,
            text_edit=types.TextEdit(
                self.edit_range(typed, after), insert if insert is not None else label
            ),
        )


# -- system files -----------------------------------------------------------------------------


def _system(here: _Here) -> list[types.CompletionItem] | None:
    path, role, text = here.path, here.cursor.role, here.cursor.text
    if path == ("connections", ITEM) and role == "value" and not text.startswith("{"):
        if "->" in text:
            return _endpoints(here, text.split("->", 1)[1].lstrip(), _INPUT_SIDE)
        return _endpoints(here, text, _OUTPUT_SIDE)
    if path[:2] == ("connections", ITEM) and len(path) == 3 and role == "value":
        side = _OUTPUT_SIDE if path[2] == "from" else _INPUT_SIDE if path[2] == "to" else None
        if side is not None:
            return _endpoints(here, text, side)
    if path in (("record", ITEM), ("plots", ITEM, "xy", ITEM), ("plots", ITEM, "y", ITEM)):
        return _endpoints(here, text, _ANY_SIDE)
    if path == ("plots", ITEM, "over"):
        return _references(here, text)
    if path == ("checks", ITEM, "expect"):
        return _expression(here, text)
    if path[:1] == ("inputs",) and len(path) >= 4 and path[2:4] == ("to", ITEM):
        return _endpoints(here, text, _SETTABLE_SIDE)
    if path[:1] == ("components",) and len(path) >= 3:
        return _component_entry(here, path[1], path[2:], role, text)
    if path == ("ros2", "nodes") and role == "key":
        return _component_names(here, text)
    if path[:2] in (("ros2", "topics"), ("ros2", "qos")) and len(path) == 2 and role == "key":
        return _endpoints(here, text, _ANY_SIDE)
    if path[:2] == ("ros2", "topics") and len(path) == 4 and role == "value":
        if path[3] == "type":
            return _message_types(here, text)
        if path[3] == "field":
            return _message_fields(here, path[2], text)
    return None


def _component_entry(
    here: _Here, name: str, rest: tuple[str, ...], role: str, text: str
) -> list[types.CompletionItem] | None:
    component = here.components.get(name)
    if rest == ("parameters",) and role == "key":
        return _ports(here, component, text, _SETTABLE_SIDE)
    if rest == ("units",) and role == "key":
        return _ports(here, component, text, _ANY_SIDE)
    if role == "value" and (rest[-1:] == ("unit",) or (len(rest) == 2 and rest[0] == "units")):
        return [here.item(n, text, _K.Unit, unit_detail(unit)) for n, unit in BUILTIN_UNITS.items()]
    if rest == ("kind",) and role == "value":
        return [
            here.item(n, text, _K.EnumMember, COMPONENT_KINDS[n].summary) for n in COMPONENT_KINDS
        ]
    if rest == ("path",) and role == "value" and here.outline is not None:
        return _files(here, text, _model_suffixes())
    return None


# -- endpoints --------------------------------------------------------------------------------

#: What a connection may start at and go to: the compiler's own rule (E030).
_OUTPUT_SIDE = SOURCE_CAUSALITIES
_INPUT_SIDE = TARGET_CAUSALITIES
#: What a system file may set a value on (parameters first: what `parameters:` is for).
_SETTABLE_SIDE = (Causality.PARAMETER, Causality.STRUCTURAL_PARAMETER, Causality.INPUT)
_ANY_SIDE = (
    Causality.OUTPUT,
    Causality.INPUT,
    Causality.PARAMETER,
    Causality.STRUCTURAL_PARAMETER,
    Causality.CALCULATED_PARAMETER,
    Causality.LOCAL,
)


def _split_typed(here: _Here, typed: str) -> tuple[ComponentOutline, str] | None:
    best = ""
    for name in here.components:
        if typed.startswith(name + ".") and len(name) > len(best):
            best = name
    if not best:
        return None
    return here.components[best], typed[len(best) + 1 :]


def _endpoints(
    here: _Here, typed: str, causalities: Sequence[Causality]
) -> list[types.CompletionItem]:
    """Component names, or after ``component.`` its ports of the given causalities.

    A YAML quote before the endpoint is no part of it; a double quote after ``component.``
    is: it opens a quoted port name.
    """
    typed = typed.strip().lstrip("'\"").rstrip("'")
    split = _split_typed(here, typed)
    if split is None:
        return _component_names(here, typed, suffix=".")
    component, partial = split
    return _ports(here, component, partial, causalities, _Naming.ENDPOINT)


def _component_names(here: _Here, typed: str, suffix: str = "") -> list[types.CompletionItem]:
    items = []
    for name, component in here.components.items():
        model = component.model.name if component.model is not None else ""
        items.append(
            here.item(
                name,
                typed,
                _K.Module,
                f"{component.kind or '?'} {model}".strip(),
                insert=name + suffix if suffix and not here.dot_after else name,
            )
        )
    return items


class _Naming(enum.Enum):
    """How a port is written where it is completed."""

    #: As the model names it: a key under ``parameters:``/``units:``, a study's target.
    MODEL = "model"
    #: As an endpoint: quoted when the name is no dotted word (``"input.1"``).
    ENDPOINT = "endpoint"
    #: In a check expression: as an endpoint, between backticks when the checks language
    #: cannot read it bare.
    CHECK = "check"


def _ports(
    here: _Here,
    component: ComponentOutline | None,
    typed: str,
    causalities: Sequence[Causality],
    naming: _Naming = _Naming.MODEL,
) -> list[types.CompletionItem]:
    if component is None or component.interface is None:
        return []
    items = []
    for port in component.interface.ports:
        if port.causality not in causalities:
            continue
        order = causalities.index(port.causality)
        if naming is _Naming.MODEL:
            kind = _K.Field if port.causality is Causality.OUTPUT else _K.Property
            items.append(
                here.item(port.name, typed, kind, port_detail(port), _port_doc(port), order=order)
            )
        else:
            items.append(_written_port(here, component.name, port, typed, naming, order))
    return items


def _written_port(
    here: _Here, component: str, port: Port, typed: str, naming: _Naming, order: int
) -> types.CompletionItem:
    """A port as an endpoint or a check writes it, replacing ``typed`` (what follows
    ``component.``): quoted when its name is no dotted word, and in a check the whole name
    between backticks when the checks language cannot read it bare (unless one is open)."""
    kind = _K.Field if port.causality is Causality.OUTPUT else _K.Property
    detail, doc = port_detail(port), _port_doc(port)
    written = endpoint_text(PortRef(component, port.name))
    label = written[len(component) + 1 :]
    after = here.port_after(typed)
    if naming is _Naming.CHECK and not _CHECK_NAME.fullmatch(written):
        opened = here.before[: len(here.before) - len(typed)].endswith(f"`{component}.")
        if not opened:
            whole, insert = f"{component}.{typed}", f"`{written}`"
            return here.item(label, whole, kind, detail, doc, order, insert, after, written)
    return here.item(label, typed, kind, detail, doc, order=order, after=after)


def _port_doc(port: Port) -> str:
    lines = [port.description] if port.description else []
    if port.start is not None:
        shown = ", ".join(str(v) for v in port.start[:8]) + (" ..." if len(port.start) > 8 else "")
        lines.append(f"start: `{shown}`")
    return "\n\n".join(lines)


def _references(here: _Here, typed: str) -> list[types.CompletionItem]:
    """``component.expected_path`` and ``component.map`` for ``over:``."""
    items = []
    for name, component in here.components.items():
        kind = COMPONENT_KINDS.get(component.kind or "")
        if component.model is not None and expected_path_file(component.model).is_file():
            label = f"{name}.{EXPECTED_PATH}"
            items.append(here.item(label, typed, _K.Reference, "the component's expected path"))
        if kind is not None and MAP in kind.capabilities:
            label = f"{name}.{MAP_REFERENCE}"
            items.append(here.item(label, typed, _K.Reference, "the scene's fixed landmarks"))
    return items


# -- the checks language ----------------------------------------------------------------------


def _expression(here: _Here, text: str) -> list[types.CompletionItem]:
    typed = name_before(text)
    if "." not in typed:
        items = [
            here.item(name, typed, _K.Function, signature, insert=f"{name}(")
            for name, signature in FUNCTIONS.items()
        ]
        items.append(here.item("time", typed, _K.Variable, "the simulation time, s", order=1))
        items += _component_names(here, typed, suffix=".")
        return items
    head, partial = split_typed_port(typed)
    if head.endswith(".site") and head.removesuffix(".site") in here.components:
        return _sites(here, here.components[head.removesuffix(".site")], partial)
    component = here.components.get(head)
    if component is None:
        return []
    items = _ports(here, component, partial, _ANY_SIDE, _Naming.CHECK)
    kind = COMPONENT_KINDS.get(component.kind or "")
    if kind is not None and SITES in kind.capabilities:
        items.append(
            here.item("site", partial, _K.Module, "named points of the scene", insert="site.")
        )
    if component.model is not None and expected_path_file(component.model).is_file():
        items.append(here.item(EXPECTED_PATH, partial, _K.Reference, "the expected path"))
    return items


def _sites(here: _Here, component: ComponentOutline, typed: str) -> list[types.CompletionItem]:
    kind = COMPONENT_KINDS.get(component.kind or "")
    if not isinstance(kind, SiteSource) or component.model is None:
        return []
    try:
        sites = kind.sites(component.model)
    except (ModelError, OSError):
        return []
    items = []
    for name, site in sites.items():
        where = ", ".join(f"{v:g}" for v in site.position)
        moving = f"; moves with `{site.moves_with}`" if site.moves_with else ""
        items.append(here.item(name, typed, _K.Constant, f"site at ({where}) m{moving}"))
    return items


# -- ROS 2 ------------------------------------------------------------------------------------


def _message_types(here: _Here, typed: str) -> list[types.CompletionItem]:
    from fmionnx.compile.ros2.messages import message_types

    return [here.item(name, typed, _K.Class) for name in message_types()]


def _message_fields(here: _Here, port: str, typed: str) -> list[types.CompletionItem]:
    from fmionnx.compile.ros2.messages import (
        FieldError,
        FieldKind,
        normalize_type,
        resolve_field,
    )

    msgtype = _topic_type(here, port)
    if msgtype is None:
        return []
    head, _, partial = typed.rpartition(".")
    try:
        info = resolve_field(normalize_type(msgtype), head)
    except (FieldError, KeyError):
        return []
    if info.kind is not FieldKind.MESSAGE:
        return []
    items = []
    for member in info.members:
        with contextlib.suppress(FieldError, KeyError):
            inner = resolve_field(normalize_type(msgtype), f"{head}.{member}" if head else member)
            detail = f"{inner.kind.value} {inner.base}"
            items.append(here.item(member, partial, _K.Field, detail))
    return items


def _topic_type(here: _Here, port: str) -> str | None:
    entry = _lookup(here.data, ("ros2", "topics", port))
    if isinstance(entry, dict) and isinstance(entry.get("type"), str):
        return str(entry["type"])
    return None


def _lookup(data: Any, path: Iterable[str]) -> Any:
    for key in path:
        if not isinstance(data, dict) or key not in data:
            return None
        data = data[key]
    return data


# -- files ------------------------------------------------------------------------------------


def _model_suffixes() -> tuple[str, ...]:
    return (".fmu", ".onnx", ".xml", ".mjb", ".csv")


def _files(here: _Here, typed: str, suffixes: tuple[str, ...]) -> list[types.CompletionItem]:
    """Files and folders next to what is typed, relative to the edited file's folder."""
    if here.outline is None:
        return []
    folder_text, _, partial = typed.rpartition("/")
    folder = here.outline.path.parent / folder_text if folder_text else here.outline.path.parent
    try:
        entries = sorted(folder.iterdir())[:500]
    except OSError:
        return []
    items = []
    for entry in entries:
        if entry.name.startswith("."):
            continue
        is_fmu_folder = entry.is_dir() and (entry / "modelDescription.xml").is_file()
        if entry.is_dir() and not is_fmu_folder:
            items.append(here.item(entry.name + "/", partial, _K.Folder, order=1))
        elif entry.name.lower().endswith(suffixes) or is_fmu_folder:
            items.append(here.item(entry.name, partial, _K.File))
    return items


# -- studies ----------------------------------------------------------------------------------


def _study(here: _Here) -> list[types.CompletionItem] | None:
    path, role, text = here.path, here.cursor.role, here.cursor.text
    if path == ("parameters",) and role == "key":
        return _targets(here, text)
    if path[:1] == ("metrics",) and len(path) == 2 and role == "value":
        return _expression(here, text)
    if path[:1] == ("objective",) and len(path) == 2 and role == "value":
        metrics = _lookup(here.data, ("metrics",))
        names = list(metrics) if isinstance(metrics, dict) else []
        return [here.item(n, text, _K.Variable, "metric") for n in names]
    if path == ("system",) and role == "value":
        return _files(here, text, (".yaml", ".yml", ".ssp", ".ssd"))
    if path == ("isolate", ITEM) and role == "value":
        items = [here.item(n, text, _K.EnumMember, d) for n, d in _ISOLATE.items()]
        return items + _component_names(here, text)
    return None


def _targets(here: _Here, typed: str) -> list[types.CompletionItem]:
    """A study's targets: ``component.parameter``, run settings, system inputs."""
    split = _split_typed(here, typed)
    if split is not None:
        return _ports(here, split[0], split[1], _SETTABLE_SIDE)
    items = [here.item(n, typed, _K.Property, d, order=2) for n, d in _RUN_TARGETS.items()]
    system = here.outline.system if here.outline is not None else None
    inputs = _lookup(system.data if system is not None else None, ("inputs",))
    if isinstance(inputs, dict):
        items += [here.item(n, typed, _K.Variable, "system input", order=1) for n in inputs]
    return items + _component_names(here, typed, suffix=".")


# -- keys and fixed values --------------------------------------------------------------------


def _schema(here: _Here, root: type[BaseModel]) -> list[types.CompletionItem]:
    def kind_of(name: str) -> str | None:
        component = here.components.get(name)
        entry = _lookup(here.data, ("components", name))
        if isinstance(entry, dict) and isinstance(entry.get("kind"), str):
            return str(entry["kind"])
        return component.kind if component is not None else None

    path, text = here.path, here.cursor.text
    wants_key = here.cursor.role == "key" or takes_mappings_only(root, path, kind_of)
    if wants_key:
        present = _lookup(here.data, path)
        have = set(present) if isinstance(present, dict) else set()
        return [
            here.item(
                key.name,
                text,
                _K.Property,
                "required" if key.required else "",
                key.description,
                order=0 if key.required else 1,
                insert=f"{key.name}: ",
            )
            for key in keys_at(root, path, kind_of)
            if key.name not in have or key.name == text
        ]
    return [here.item(value, text, _K.EnumMember) for value in values_at(root, path, kind_of)]
