"""SSP front end: ``.ssp`` archives and loose ``.ssd`` files -> :class:`SystemSpec` + spans.

The result is the same raw model the YAML front end produces, so one compiler and one IR
serve both formats. Steps: unpack the archive (safely, into a cache folder keyed by its
hash), parse the SSD without entities or network, validate it against the XSD of its SSP
version (E070), read it into typed records, flatten nested systems and bindings, and build
the plain data a YAML file would have held, recording for every key path the line of the
SSD (or ``.ssv``) element it came from. See ``docs/ssp.md`` for what is supported.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Severity, Span
from fmionnx.core.errors import ModelError
from fmionnx.core.types import ValueSource
from fmionnx.kinds.base import FMI
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.model import DOTTED_NAME, SystemSpec
from fmionnx.spec.pydantic_errors import report_validation_error
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.ssp_archive import SSD_NAME, unpack_ssp
from fmionnx.spec.ssp_flatten import FlatSystem, flatten
from fmionnx.spec.ssp_params import resolve_uri
from fmionnx.spec.ssp_tree import Annotation, Document, Element, read_document, report_unread
from fmionnx.spec.ssp_xml import parse_xml, validate
from fmionnx.spec.yaml import LoadedSpec

#: Component MIME types and the kinds they select (docs/ssp.md), from the kind table. SSP
#: itself defines only the FMU type; the others are ours.
KIND_BY_MIME = {kind.mime_type: name for name, kind in COMPONENT_KINDS.items()}
MIME_BY_KIND = {kind: mime for mime, kind in KIND_BY_MIME.items()}
#: SSD ``implementation`` attribute -> FMU ``interface`` option.
INTERFACE_BY_IMPLEMENTATION = {"CoSimulation": "cs", "ModelExchange": "me"}
#: Keys of the component spec that come from SSD elements, never from our annotation.
_STRUCTURAL_KEYS = ("kind", "path")
#: System annotation key: root connectors that stay system inputs although a value is bound
#: to them (``fmionnx export`` writes an ``inputs:`` entry with a ``value`` and ports so).
BOUND_INPUTS = "bound_inputs"
#: Component annotation key: the component's parameter names in the order written, when its
#: values come from both the ``.ssv`` and the annotation.
PARAMETER_ORDER = "parameter_order"
#: Keys our system-level annotation may carry (``inputs``: values of system inputs that an
#: ``.ssv`` cannot hold, by input name).
SYSTEM_ANNOTATION_KEYS = (
    "description",
    "run",
    "record",
    "plots",
    "checks",
    "ros2",
    "inputs",
    BOUND_INPUTS,
)


def load_ssp_system(path: Path, bag: DiagnosticBag) -> LoadedSpec:
    """Load an ``.ssp`` archive or a loose ``.ssd`` file; every problem goes into ``bag``."""
    sources = SourceMap(path)
    if path.suffix.lower() == ".ssp":
        try:
            root: Path | None = unpack_ssp(path)
        except ModelError as exc:
            bag.emit(exc.code, f"`{path.name}`: {exc}", Span(path), hint=exc.hint)
            return LoadedSpec(None, sources, path)
        assert root is not None
        ssd = root / SSD_NAME
        if not ssd.is_file():
            bag.emit(
                codes.SSP_REFERENCE,
                f"`{path.name}` has no `{SSD_NAME}` at its root",
                Span(path),
                hint="an SSP archive holds the system structure as SystemStructure.ssd",
            )
            return LoadedSpec(None, sources, path)
    else:
        root, ssd = None, path
        if not path.is_file():
            code = codes.FILE_NOT_FOUND if not path.exists() else codes.NOT_A_FILE
            bag.emit(code, f"system file `{path}` does not exist or is not a file", Span(path))
            return LoadedSpec(None, sources, path)
    sources = SourceMap(ssd)
    errors_before = _errors(bag)
    tree = parse_xml(ssd, bag)
    if tree is None or not validate(tree, "ssd", ssd, bag):
        return LoadedSpec(None, sources, path)
    report_unread(tree, ssd, bag)
    document = read_document(tree)
    annotation = _system_annotation(document, ssd, bag)
    names = _bound_inputs(annotation, document, ssd, bag)
    flat = flatten(document, ssd, root, bag, names or frozenset())
    data = None
    if annotation is not None and names is not None:
        data = _system_data(document, annotation, flat, ssd, root, sources, bag)
    if data is None or _errors(bag) > errors_before:
        return LoadedSpec(None, sources, path)
    try:
        spec = SystemSpec.model_validate(data)
    except ValidationError as exc:
        report_validation_error(exc, data, sources, bag)
        return LoadedSpec(None, sources, path)
    return LoadedSpec(spec, sources, path)


def _errors(bag: DiagnosticBag) -> int:
    return sum(1 for d in bag if d.severity is Severity.ERROR)


def _json_object(annotation: Annotation, ssd: Path, bag: DiagnosticBag) -> dict[str, Any] | None:
    span = Span(ssd, annotation.line)
    try:
        value = json.loads(annotation.text) if annotation.text else {}
    except json.JSONDecodeError as exc:
        bag.emit(
            codes.INVALID_VALUE, f"the `org.fmionnx` annotation is not valid JSON: {exc.msg}", span
        )
        return None
    if not isinstance(value, dict):
        bag.emit(codes.INVALID_VALUE, "the `org.fmionnx` annotation must hold a JSON object", span)
        return None
    return value


def _annotation_span(document: Document, ssd: Path) -> Span:
    where = document.annotation.line if document.annotation is not None else document.line
    return Span(ssd, where)


def _system_annotation(document: Document, ssd: Path, bag: DiagnosticBag) -> dict[str, Any] | None:
    """The SSD's ``org.fmionnx`` object (``{}`` without one); None: invalid (E003/E002)."""
    if document.annotation is None:
        return {}
    parsed = _json_object(document.annotation, ssd, bag)
    if parsed is None:
        return None
    for key in parsed:
        if key not in SYSTEM_ANNOTATION_KEYS:
            bag.emit(
                codes.UNKNOWN_KEY,
                f"unknown key `{key}` in the system's `org.fmionnx` annotation",
                _annotation_span(document, ssd),
                hint=f"expected one of {', '.join(SYSTEM_ANNOTATION_KEYS)}",
            )
            return None
    return parsed


def _bound_inputs(
    annotation: dict[str, Any] | None, document: Document, ssd: Path, bag: DiagnosticBag
) -> frozenset[str] | None:
    """The root connectors the annotation keeps as system inputs; None: not a list (E003).

    Read before flattening, which needs them: a bound root connector is otherwise a value
    flowing to the ports it reaches, as other tools mean it.
    """
    names = (annotation or {}).get(BOUND_INPUTS, [])
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        bag.emit(
            codes.INVALID_VALUE,
            f"`{BOUND_INPUTS}` in the system's `org.fmionnx` annotation must list system "
            "input names",
            _annotation_span(document, ssd),
        )
        return None
    return frozenset(names)


def system_name(text: str, span: Span, bag: DiagnosticBag) -> str:
    """The SSD name as a system-file name (``[A-Za-z_][\\w-]*``), warning when changed."""
    name = re.sub(r"[^\w-]", "_", text) or "system"
    if not re.match(r"[A-Za-z_]", name):
        name = "_" + name
    if name != text:
        bag.emit(codes.SSP_IGNORED, f"system name `{text}` is used as `{name}`", span)
    return name


def _system_data(
    document: Document,
    annotation: dict[str, Any],
    flat: FlatSystem,
    ssd: Path,
    root: Path | None,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> dict[str, Any] | None:
    top = Span(ssd, document.line)
    sources.record((), top)
    annotation = dict(annotation)
    annotation.pop(BOUND_INPUTS, None)  # used by flattening already
    annotation_span = _annotation_span(document, ssd)
    for key in annotation:
        sources.record((key,), annotation_span, annotation_span)
    run: dict[str, Any] = {}
    if document.start is not None:
        run["start"] = document.start
    if document.stop is not None:
        run["stop"] = document.stop
    if document.root.step is not None:
        run["step"] = document.root.step
    extra_run = annotation.pop("run", {})
    input_values = annotation.pop("inputs", {})
    sources.record(("run",), annotation_span if extra_run else top, top)
    overridden = isinstance(extra_run, dict) and "step" in extra_run
    if document.root.step is not None and not overridden:
        step_span = Span(ssd, document.root.step_line)
        sources.record(("run", "step"), step_span, step_span)
    if document.root.description:
        data_description = {"description": document.root.description}
        sources.record(("description",), Span(ssd, document.root.line))
    else:
        data_description = {}
    data: dict[str, Any] = {
        **data_description,
        "fmionnx": 1,
        "name": system_name(document.name, top, bag),
        # A non-mapping `run` is left for the schema check to report.
        "run": {**run, **extra_run} if isinstance(extra_run, dict) else extra_run,
        **annotation,
    }
    sources.record(("fmionnx",), top, top)
    sources.record(("name",), top, top)
    components: dict[str, Any] = {}
    sources.record(("components",), Span(ssd, document.root.line), Span(ssd, document.root.line))
    for name, element in flat.components.items():
        entry = _component(name, element, flat, ssd, root, sources, bag)
        if entry is not None:
            components[name] = entry
    data["components"] = components
    sources.record(("connections",), Span(ssd, document.root.line))
    data["connections"] = _connections(flat, ssd, sources)
    inputs = _inputs(flat, ssd, sources, bag)
    if not _input_values(input_values, inputs, annotation_span, sources, bag):
        return None
    if inputs:
        sources.record(("inputs",), Span(ssd, document.root.line))
        # In the order their connectors are declared (the order the file's author, or the
        # system file `fmionnx export` wrote, gave them), whatever set their values.
        last = len(flat.declared)
        data["inputs"] = dict(sorted(inputs.items(), key=lambda i: flat.declared.get(i[0], last)))
    return data


def _component(
    name: str,
    element: Element,
    flat: FlatSystem,
    ssd: Path,
    root: Path | None,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> dict[str, Any] | None:
    span = Span(ssd, element.line)
    key: tuple[str, ...] = ("components", name)
    sources.record(key, span, span)
    kind = KIND_BY_MIME.get(element.type)
    if kind is None:
        bag.emit(
            codes.SSP_UNSUPPORTED,
            f"component `{name}` has type `{element.type}`, which fmionnx cannot run",
            span,
            hint=f"supported types: {', '.join(KIND_BY_MIME)}",
        )
        return None
    if element.source is None:
        bag.emit(codes.SSP_REFERENCE, f"component `{name}` has no `source`", span)
        return None
    entry: dict[str, Any] = {"kind": kind}
    # `source=""` refers to the SSD itself: a component defined by its annotation, with no
    # model file. Only kinds whose entry may omit `path` accept that.
    if not element.source and COMPONENT_KINDS[kind].spec_model.model_fields["path"].is_required():
        bag.emit(
            codes.SSP_REFERENCE,
            f"component `{name}` has an empty `source`: it needs a model file",
            span,
        )
        return None
    if element.source:
        model = resolve_uri(element.source, ssd.parent, root, span, bag)
        if model is None:
            return None
        entry["path"] = str(model)
    for field_name in ("kind", "path"):
        sources.record((*key, field_name), span, span)
    if FMI in COMPONENT_KINDS[kind].capabilities and (
        element.implementation in INTERFACE_BY_IMPLEMENTATION
    ):
        entry["interface"] = INTERFACE_BY_IMPLEMENTATION[element.implementation]
        sources.record((*key, "interface"), span, span)
    parameters: dict[str, Any] = {}
    order: list[str] = []
    if element.annotation is not None:
        options = _json_object(element.annotation, ssd, bag)
        if options is None:
            return None
        option_span = Span(ssd, element.annotation.line)
        order = options.pop(PARAMETER_ORDER, [])
        if not isinstance(order, list) or not all(isinstance(n, str) for n in order):
            bag.emit(
                codes.INVALID_VALUE,
                f"`{PARAMETER_ORDER}` of component `{name}` must list parameter names",
                option_span,
            )
            return None
        for option in options:
            if option in _STRUCTURAL_KEYS:
                bag.emit(
                    codes.UNKNOWN_KEY,
                    f"`{option}` of component `{name}` comes from the SSD element, not from "
                    "the annotation",
                    option_span,
                )
                return None
            sources.record((*key, option), option_span, option_span)
        extra = options.pop("parameters", {})
        if isinstance(extra, dict):
            parameters.update(extra)
            for parameter in extra:
                sources.record((*key, "parameters", parameter), option_span, option_span)
                sources.sources[(*key, "parameters", parameter)] = ValueSource.SSP_ANNOTATION
        entry.update(options)
    bound = flat.parameters.get(name, {})
    for parameter, value in bound.items():
        parameters[parameter] = value.value
        sources.record((*key, "parameters", parameter), value.span, value.span)
        sources.sources[(*key, "parameters", parameter)] = value.origin
        if value.unit is not None:
            sources.units[(*key, "parameters", parameter)] = value.unit
    if parameters:
        entry["parameters"] = _in_order(parameters, order)
        if (*key, "parameters") not in sources.spans:
            sources.record((*key, "parameters"), span, span)
    return entry


def _in_order(parameters: dict[str, Any], order: list[str]) -> dict[str, Any]:
    """``parameters`` in the annotation's ``order`` (the system file's), others after it.

    The ``.ssv`` and the annotation each hold some of a component's values; the order of a
    component's parameters is part of its compiled system, so it is restored as written.
    A name the order lists but no binding sets (removed by another tool) is skipped.
    """
    ranks = {name: rank for rank, name in enumerate(order)}
    last = len(ranks)
    return dict(sorted(parameters.items(), key=lambda item: ranks.get(item[0], last)))


def _inputs(flat: FlatSystem, ssd: Path, sources: SourceMap, bag: DiagnosticBag) -> dict[str, Any]:
    """Open system connectors as ``inputs:`` entries, named ``conn`` or ``sub.conn``."""
    result: dict[str, Any] = {}
    for name, item in flat.inputs.items():
        span = Span(ssd, item.line)
        if not item.targets and item.value is None:  # its connections were refused already
            continue
        if not DOTTED_NAME.fullmatch(name):
            bag.emit(
                codes.SSP_IGNORED,
                f"open system connector `{name}` cannot be named on the command line (letters, "
                "digits, `_`, `-` only); the ports it reaches keep their start values",
                span,
            )
            continue
        targets: list[Any] = []
        sources.record(("inputs", name), span, span)
        for index, target in enumerate(item.targets):
            sources.record(("inputs", name, "to", index), Span(ssd, target.line))
            if target.factor == 1.0 and target.offset == 0.0:
                targets.append(target.endpoint)
            else:
                targets.append(
                    {"to": target.endpoint, "factor": target.factor, "offset": target.offset}
                )
        result[name] = {"to": targets}
        if item.value is not None:
            result[name]["value"] = item.value.value
            sources.record(("inputs", name, "value"), item.value.span, item.value.span)
            sources.sources[("inputs", name, "value")] = item.value.origin
    return result


def _input_values(
    values: object,
    inputs: dict[str, Any],
    span: Span,
    sources: SourceMap,
    bag: DiagnosticBag,
) -> bool:
    """Put the annotation's system input values on their ``inputs:`` entries (False: E003).

    ``fmionnx export`` writes a value there when ``ssv:Integer`` (32 bits) cannot hold it; an
    input with no connection gets an entry of its own, as a bound unconnected connector does.
    """
    if not isinstance(values, dict):
        bag.emit(
            codes.INVALID_VALUE,
            "`inputs` in the system's `org.fmionnx` annotation must map input names to values",
            span,
        )
        return False
    for name, value in values.items():
        entry = inputs.setdefault(name, {"to": []})
        entry["value"] = value
        if ("inputs", name) not in sources.spans:
            sources.record(("inputs", name), span, span)
        sources.record(("inputs", name, "value"), span, span)
        sources.sources[("inputs", name, "value")] = ValueSource.SSP_ANNOTATION
    return True


def _connections(flat: FlatSystem, ssd: Path, sources: SourceMap) -> list[Any]:
    result: list[Any] = []
    for index, connection in enumerate(flat.connections):
        # Column 0: the compiler computes columns inside one-line YAML connections only.
        span = Span(ssd, connection.line)
        for path in (("connections", index), ("connections", index, "from")):
            sources.record(path, span, span)
        sources.record(("connections", index, "to"), span, span)
        plain = connection.factor == 1.0 and connection.offset == 0.0
        if plain and connection.convert_units:
            result.append(f"{connection.src} -> {connection.dst}")
        else:
            entry: dict[str, Any] = {"from": connection.src, "to": connection.dst}
            if not plain:
                entry.update(factor=connection.factor, offset=connection.offset)
            if not connection.convert_units:
                entry["convert_units"] = False
            result.append(entry)
    return result
