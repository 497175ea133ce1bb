"""Write a system as an SSP 1.0 archive that FMPy, libcosim and OMSimulator can open.

The archive holds ``SystemStructure.ssd`` (validated against the SSP 1.0 XSD before it is
packed), the models under ``resources/`` and one ``.ssv`` per component with scalar
parameters. SSP 1.0 is written because FMPy reads only 1.0 and every 2.0 reader reads 1.0.
What SSP cannot say (component periods, ONNX/MuJoCo options, array parameters, integers
beyond ``ssv:Integer``'s 32 bits, the base step, record/plots/checks/ros2 sections) goes into
``org.fmionnx`` annotations as JSON, so that ``fmionnx convert`` gives the system file back,
in the order it was written: a component's parameters split between its ``.ssv`` and the
annotation are listed there in order (``parameter_order``), and the system inputs keep the
order of their connectors. The layout is flat: one root system whose components keep their
(possibly dotted) names; connections are component to component.
"""

from __future__ import annotations

import json
import re
import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import Any

from lxml import etree

from fmionnx.compile.endpoints import split_endpoint
from fmionnx.compile.expected_path import expected_path_file
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.resolve import model_path
from fmionnx.core.archive import write_deterministic_zip
from fmionnx.core.errors import FmionnxError, ModelError
from fmionnx.core.modelfiles import ModelFile, ShippingError, copy_model_files, regular_file
from fmionnx.core.resources import SSP_XML_BYTES
from fmionnx.core.safewrite import refuse
from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.core.types import Causality, DType, Port
from fmionnx.core.units import BASE_UNITS, Unit
from fmionnx.kinds.base import FMI, ShipsFiles
from fmionnx.kinds.registry import COMPONENT_KINDS, model_files
from fmionnx.spec.model import ConnectionSpec, InputTargetSpec, SystemSpec, split_connection
from fmionnx.spec.ssp import BOUND_INPUTS, MIME_BY_KIND, PARAMETER_ORDER
from fmionnx.spec.ssp_archive import SSD_NAME
from fmionnx.spec.ssp_names import port_label_to_fmi
from fmionnx.spec.ssp_tree import FMIONNX_ANNOTATION
from fmionnx.spec.ssp_xml import NS, schema

#: Namespace of the element inside our annotations (never fetched; a name only).
FMIONNX_NS = "https://fmionnx.dev/ssp/1"
SSP_VERSION = "1.0"

_IMPLEMENTATION = {"cs": "CoSimulation", "me": "ModelExchange"}
_NSMAP = {"ssd": NS["ssd"], "ssc": NS["ssc"], "ssv": NS["ssv"], "fmionnx": FMIONNX_NS}


class ExportError(FmionnxError):
    """The system cannot be written as SSP (a model file is missing, the output unwritable)."""


def _q(prefix: str, name: str) -> str:
    return f"{{{_NSMAP[prefix]}}}{name}"


def _sub(parent: Any, prefix: str, local: str, /, **attributes: str) -> Any:
    return etree.SubElement(parent, _q(prefix, local), attributes)


def _annotation(parent: Any, payload: dict[str, Any]) -> None:
    annotations = _sub(parent, "ssd", "Annotations")
    annotation = _sub(annotations, "ssc", "Annotation", type=FMIONNX_ANNOTATION)
    options = _sub(annotation, "fmionnx", "Options")
    # Keys in the order the system file has them (not sorted): the order of a signal's
    # outputs, for one, is the order of its ports and of the results' columns.
    options.text = json.dumps(payload)


def _type_element(parent: Any, port: Port | None, units: dict[str, Unit]) -> None:
    """The connector's ``ssc:`` type from the compiled port (omitted without one).

    A unit with a definition is collected in ``units`` for ``ssd:Units`` (the first definition
    of a name wins), so that a reader of the file converts between connector units as the
    compiler converted between port units.
    """
    if port is None:
        return
    if port.dtype.is_float:
        typed = _sub(parent, "ssc", "Real")
        if port.unit:
            typed.set("unit", port.unit)
            if port.unit_definition is not None:
                units.setdefault(port.unit, port.unit_definition)
    elif port.dtype.is_integer:
        _sub(parent, "ssc", "Integer")
    elif port.dtype is DType.BOOL:
        _sub(parent, "ssc", "Boolean")
    elif port.dtype is DType.STRING:
        _sub(parent, "ssc", "String")
    else:
        _sub(parent, "ssc", "Binary")


def _units_element(parent: Any, units: dict[str, Unit]) -> None:
    """``ssd:Units``: each connector unit with its SI exponents, factor and offset."""
    element = _sub(parent, "ssd", "Units")
    for name, unit in units.items():
        node = _sub(element, "ssc", "Unit", name=name)
        base = _sub(node, "ssc", "BaseUnit")
        for symbol, power in zip(BASE_UNITS, unit.exponents, strict=True):
            if power:
                base.set(symbol, str(power))
        if unit.factor != 1.0:
            base.set("factor", repr(unit.factor))
        if unit.offset != 0.0:
            base.set("offset", repr(unit.offset))


_KIND_BY_CAUSALITY = {
    Causality.INPUT: "input",
    Causality.OUTPUT: "output",
    Causality.PARAMETER: "parameter",
    Causality.STRUCTURAL_PARAMETER: "parameter",
    Causality.CALCULATED_PARAMETER: "calculatedParameter",
}


class _Writer:
    def __init__(self, spec: SystemSpec, base: Path, system: CompiledSystem | None) -> None:
        self.spec = spec
        self.base = base
        self.system = system
        # component -> connector label -> (kind, port or None)
        self.connectors: dict[str, dict[str, tuple[str, Port | None]]] = {
            name: {} for name in spec.components
        }
        self.units: dict[str, Unit] = {}
        #: System input values an ``.ssv`` cannot hold, for the system's annotation.
        self.input_values: dict[str, Any] = {}
        #: System inputs whose value is bound on the root system and that reach ports: the
        #: annotation names them, so that the reader keeps them inputs (see :meth:`inputs`).
        self.bound_inputs: list[str] = []

    def _port(self, component: str, port: str) -> Port | None:
        if self.system is None:
            return None
        interface = self.system.component(component).interface
        return interface.port(port)

    def _endpoint(self, text: str, default_kind: str) -> tuple[str, str]:
        parts = split_endpoint(text, self.spec.components)
        if parts is None or parts[0] not in self.spec.components:
            msg = f"connection endpoint `{text}` names no component of the system"
            raise ExportError(msg)
        component, port, index = parts
        label = port if index is None else f"{port}[{index.replace(' ', '')}]"
        if FMI in COMPONENT_KINDS[self.spec.components[component].kind].capabilities:
            label = port_label_to_fmi(label)
        found = self._port(component, port)
        kind = _KIND_BY_CAUSALITY.get(found.causality, default_kind) if found else default_kind
        self.connectors[component].setdefault(label, (kind, found))
        return component, label

    def connections(self, parent: Any) -> None:
        entries = []
        for entry in self.spec.connections:
            convert = True
            if isinstance(entry, ConnectionSpec):
                left, right, factor, offset = entry.from_, entry.to, entry.factor, entry.offset
                convert = entry.convert_units
            else:
                parts = split_connection(entry)
                if parts is None:
                    msg = f"`{entry}` is not a connection"
                    raise ExportError(msg)
                (left, right), factor, offset = parts, 1.0, 0.0
            src = self._endpoint(left, "output")
            dst = self._endpoint(right, "input")
            entries.append((src, dst, factor, offset, convert))
        if not entries:
            return
        connections = _sub(parent, "ssd", "Connections")
        for src, dst, factor, offset, convert in entries:
            node = _sub(
                connections,
                "ssd",
                "Connection",
                startElement=src[0],
                startConnector=src[1],
                endElement=dst[0],
                endConnector=dst[1],
            )
            if not convert:
                node.set("suppressUnitConversion", "true")
            if factor != 1.0 or offset != 0.0:
                _sub(node, "ssc", "LinearTransformation", factor=repr(factor), offset=repr(offset))

    def inputs(self, system: Any, scratch: Any) -> None:
        """System inputs as connectors of the root system connected to the ports they set.

        This is how other tools write a system's top-level inputs and parameters, and how the
        SSP front end reads them back as open connectors, transformations included. The kind
        is ``parameter`` when every target is a parameter, else ``input``. A value goes into a
        binding on the root system, typed like the targets (``ssv:Real`` for Real ports, as a
        component's parameters); one that also reaches ports is named in the annotation's
        ``bound_inputs``, so that fmionnx reads it back as that input's value (other tools'
        bound connectors are values for the ports they reach, and stay so).
        """
        if not self.spec.inputs:
            return
        connectors = etree.Element(_q("ssd", "Connectors"))
        system.insert(0, connectors)  # before Elements, as the schema orders them
        connections = scratch.find(_q("ssd", "Connections"))
        if connections is None:
            connections = _sub(scratch, "ssd", "Connections")
        typed_by: dict[str, Port | None] = {}
        for name, entry in self.spec.inputs.items():
            kinds: set[str] = set()
            floats = True
            first: Port | None = None
            for item in entry.to:
                target = item if isinstance(item, InputTargetSpec) else InputTargetSpec(to=item)
                component, label = self._endpoint(target.to, "input")
                kind, port = self.connectors[component][label]
                kinds.add(kind)
                floats = floats and port is not None and port.dtype.is_float
                if first is None:
                    first = port
                node = _sub(
                    connections,
                    "ssd",
                    "Connection",
                    startConnector=name,
                    endElement=component,
                    endConnector=label,
                )
                if target.factor != 1.0 or target.offset != 0.0:
                    _sub(
                        node,
                        "ssc",
                        "LinearTransformation",
                        factor=repr(target.factor),
                        offset=repr(target.offset),
                    )
            kind = "parameter" if kinds == {"parameter"} else "input"
            connector = _sub(connectors, "ssd", "Connector", name=name, kind=kind)
            if not entry.to and entry.value is not None:  # only its value says its type
                _sub(connector, "ssc", _ssv_type(entry.value, None)[0])
            elif floats:  # no unit: each target keeps its own, through its transformation
                _sub(connector, "ssc", "Real")
            # Real targets make the value a Real, as for a component's parameter (libcosim
            # refuses an ssv:Integer for a Real); other targets leave it typed by its value.
            typed_by[name] = first if entry.to and floats else None
        if not len(connections):  # inputs that only hold values: the schema wants none empty
            scratch.remove(connections)
        held: dict[str, Any] = {}
        for name, entry in self.spec.inputs.items():
            if entry.value is None:
                continue
            # Whether an .ssv holds it exactly goes by the value as written: an integer
            # beyond 32 bits keeps its type in our annotation even with Real targets.
            if _ssv_holds(entry.value, None):
                held[name] = entry.value
                if entry.to:
                    self.bound_inputs.append(name)
            else:
                self.input_values[name] = entry.value
        if held:  # values of their own: a binding on the root system, as tools write them
            bindings = etree.Element(_q("ssd", "ParameterBindings"))
            system.insert(1, bindings)  # after Connectors, before Elements
            binding = _sub(bindings, "ssd", "ParameterBinding")
            values = _sub(binding, "ssd", "ParameterValues")
            parameter_set = _sub(values, "ssv", "ParameterSet", version=SSP_VERSION, name="inputs")
            parameters = _sub(parameter_set, "ssv", "Parameters")
            for name, value in held.items():
                parameter = _sub(parameters, "ssv", "Parameter", name=name)
                element, text = _ssv_type(value, typed_by[name])
                _sub(parameter, "ssv", element, value=text)

    def component(self, parent: Any, name: str, spec: ComponentSpecBase, staging: Path) -> None:
        source = self._pack(name, spec, staging)
        node = _sub(parent, "ssd", "Component", name=name, type=MIME_BY_KIND[spec.kind])
        node.set("source", source)
        interface = getattr(spec, "interface", None)
        if interface is not None:
            node.set("implementation", _IMPLEMENTATION[interface])
        if self.connectors[name]:
            connectors = _sub(node, "ssd", "Connectors")
            for label, (kind, port) in self.connectors[name].items():
                connector = _sub(connectors, "ssd", "Connector", name=label, kind=kind)
                _type_element(connector, port, self.units)
        ports = {key: self._port(name, key) for key in spec.parameters}
        scalars = {k: v for k, v in spec.parameters.items() if _ssv_holds(v, ports[k])}
        # Arrays, and integers beyond ssv:Integer: in our annotation, exactly as written.
        others = {k: v for k, v in spec.parameters.items() if k not in scalars}
        if scalars:
            ssv = f"resources/{name}.ssv"
            _write_ssv(staging / ssv, name, scalars, ports)
            bindings = _sub(node, "ssd", "ParameterBindings")
            _sub(bindings, "ssd", "ParameterBinding", source=ssv)
        options = spec.model_dump(mode="json", by_alias=True, exclude_defaults=True)
        for key in ("kind", "path", "parameters", "interface"):
            options.pop(key, None)
        if others:
            options["parameters"] = others
        if others and scalars:  # from two places: the reader restores the order as written
            options[PARAMETER_ORDER] = list(spec.parameters)
        if options:
            _annotation(node, options)

    def _pack(self, name: str, spec: ComponentSpecBase, staging: Path) -> str:
        """Copy the component's model under ``resources/``; its path inside the archive.

        An entry without a model file gets the empty reference ``source=""`` (SSP 1.0 requires
        the attribute): an empty URI reference is the SSD itself, which holds the component's
        definition in its annotation.
        """
        if not spec.has_model_file:
            return ""
        source = model_path(self.base, spec.path)
        if not source.exists():
            msg = f"component `{name}`: `{source}` does not exist"
            raise ExportError(msg)
        kind = COMPONENT_KINDS[spec.kind]
        try:
            files = model_files(spec.kind, source)
            if isinstance(kind, ShipsFiles):  # the model needs files beside it: a folder
                folder = f"resources/{name}"
                copy_model_files(source, (*files, *_companions(source)), staging / folder)
                return f"{folder}/{source.name}"
            suffix = kind.suffixes[0] if source.is_dir() else source.suffix or kind.suffixes[0]
            target = f"resources/{name}{suffix}"
            (staging / "resources").mkdir(exist_ok=True)
            if source.is_dir():  # an unpacked model (FMU): zipped, as the format wants it
                unpacked = staging / ".unpacked" / name
                copy_model_files(source, files, unpacked)
                write_deterministic_zip(unpacked / source.name, staging / target)
                shutil.rmtree(staging / ".unpacked")
            else:
                (only,) = files
                copy_model_files(source, [ModelFile(target, only.source)], staging)
        except ShippingError as exc:
            raise ExportError(f"component `{name}`: {exc}") from None
        return target


def _companions(model: Path) -> tuple[ModelFile, ...]:
    """Files fmionnx itself finds beside a model: its expected path (``<stem>.path.csv``),
    which plots and checks of the converted system look for there again."""
    path = expected_path_file(model)
    if not (path.exists() or path.is_symlink()):
        return ()
    return (regular_file(model.parent, path, model),)


#: Values of ``ssv:Integer`` (``xs:int`` in SSP 1.0 and 2.0): 32-bit signed.
_SSV_INTEGERS = range(-(2**31), 2**31)


def _ssv_holds(value: Any, port: Port | None) -> bool:
    """Whether an ``.ssv`` holds ``value`` without loss: a scalar, an Integer within 32 bits.

    A 64-bit or unsigned 32-bit FMI integer may exceed ``xs:int``; such a value goes into our
    annotation, as arrays do, rather than into an ``ssv:Real`` that would change its type and,
    beyond 2**53, its value.
    """
    if isinstance(value, list):
        return False
    element, text = _ssv_type(value, port)
    return element != "Integer" or int(text) in _SSV_INTEGERS


def _ssv_type(value: Any, port: Port | None) -> tuple[str, str]:
    """SSV element and value text; the port's type wins (libcosim rejects Integer for Real)."""
    if port is not None and port.dtype.is_float and not isinstance(value, bool | str):
        return "Real", repr(float(value))
    if isinstance(value, bool):
        return "Boolean", "true" if value else "false"
    if isinstance(value, int):
        return "Integer", str(value)
    if isinstance(value, float):
        return "Real", repr(value)
    return "String", str(value)


def _write_ssv(
    path: Path, name: str, values: dict[str, Any], ports: dict[str, Port | None]
) -> None:
    root = etree.Element(_q("ssv", "ParameterSet"), nsmap={"ssv": NS["ssv"]})
    root.set("version", SSP_VERSION)
    root.set("name", name)
    parameters = _sub(root, "ssv", "Parameters")
    for key, value in values.items():
        parameter = _sub(parameters, "ssv", "Parameter", name=key)
        element, text = _ssv_type(value, ports.get(key))
        _sub(parameter, "ssv", element, value=text)
    _check(root, "ssv", path.name)
    path.parent.mkdir(parents=True, exist_ok=True)
    etree.ElementTree(root).write(
        str(path), xml_declaration=True, encoding="UTF-8", pretty_print=True
    )


def _check(root: Any, kind: str, name: str) -> None:
    """Every file we write validates against the SSP 1.0 XSD; anything else is our bug."""
    xsd = schema(kind, "1")
    if not xsd.validate(etree.ElementTree(root)):
        problems = "; ".join(str(e.message) for e in xsd.error_log)
        msg = f"internal error: the {name} fmionnx wrote does not validate: {problems}"
        raise FmionnxError(msg)


def build_ssd(spec: SystemSpec, base: Path, staging: Path, system: CompiledSystem | None) -> Any:
    """The SSD element tree; models and ``.ssv`` files are written under ``staging``."""
    writer = _Writer(spec, base, system)
    root = etree.Element(_q("ssd", "SystemStructureDescription"), nsmap=_NSMAP)
    root.set("version", SSP_VERSION)
    root.set("name", spec.name)
    root.set("generationTool", "fmionnx")
    top = _sub(root, "ssd", "System", name=spec.name)
    if spec.description:
        top.set("description", spec.description)
    elements = _sub(top, "ssd", "Elements")
    # Connections first: they decide which connectors each component declares.
    scratch = etree.Element("scratch")
    writer.connections(scratch)
    writer.inputs(top, scratch)
    for name, component in spec.components.items():
        writer.component(elements, name, component, staging)
    for child in scratch:
        top.append(child)
    if writer.units:
        _units_element(root, writer.units)
    experiment = _sub(root, "ssd", "DefaultExperiment", startTime=repr(spec.run.start))
    if spec.run.stop is not None:
        experiment.set("stopTime", repr(spec.run.stop))
    settings = spec.model_dump(
        mode="json",
        by_alias=True,
        exclude_defaults=True,
        include={"record", "plots", "checks", "ros2"},
    )
    run = spec.run.model_dump(mode="json", include={"step", "output_interval"}, exclude_none=True)
    if run:  # SSP's DefaultExperiment has neither (1.0 nor 2.0): our annotation carries them
        settings["run"] = run
    if writer.input_values:  # beyond ssv:Integer: read back onto the `inputs:` entries
        settings["inputs"] = writer.input_values
    if writer.bound_inputs:  # their bound values stay theirs: read back as `inputs:` values
        settings[BOUND_INPUTS] = writer.bound_inputs
    if settings:
        _annotation(root, settings)
    _check(root, "ssd", SSD_NAME)
    return root


#: The root element of an SSD this writer made (``build_ssd`` sets the attribute).
_OURS = re.compile(rb'<[^>]*SystemStructureDescription[^>]*generationTool="fmionnx"')


def written_by_fmionnx(path: Path) -> bool:
    """``path`` is a regular file: an SSP whose SSD says ``generationTool="fmionnx"``."""
    if path.is_symlink() or not path.is_file():
        return False
    try:
        with zipfile.ZipFile(path) as archive:
            if archive.getinfo(SSD_NAME).file_size > SSP_XML_BYTES.value():
                return False  # not read: whatever it is, it is no SSD of ours
            ssd = archive.read(SSD_NAME)
    except (OSError, KeyError, zipfile.BadZipFile, ModelError):
        return False
    return _OURS.search(ssd) is not None


def check_export_target(output: Path, *, force: bool) -> None:
    """Raise :class:`OverwriteRefusedError` when ``output`` holds a file fmionnx did not write.

    Re-exporting over an SSP fmionnx exported is the normal edit loop and needs no option;
    replacing a vendor's archive (or anything else) does.
    """
    if force:
        return
    if output.is_symlink() or (output.exists() and not written_by_fmionnx(output)):
        raise refuse(output, "exists and was not written by `fmionnx export`")


def export_ssp(
    spec: SystemSpec,
    base: Path,
    output: Path,
    system: CompiledSystem | None = None,
    *,
    force: bool = False,
) -> None:
    """Write ``spec`` (paths relative to ``base``) as an SSP archive at ``output``.

    ``system`` (the compiled IR, when available) adds connector kinds, types and units. The
    archive appears at ``output`` only when complete. Raises :class:`ExportError`, and
    :class:`OverwriteRefusedError` (before writing anything) when ``output`` is not ours.
    """
    check_export_target(output, force=force)
    output.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".export-", dir=output.parent))
    try:
        root = build_ssd(spec, base, staging, system)
        etree.ElementTree(root).write(
            str(staging / SSD_NAME), xml_declaration=True, encoding="UTF-8", pretty_print=True
        )
        write_deterministic_zip(staging, output)
    except (OSError, ModelError) as exc:
        msg = f"cannot write `{output}`: {exc}"
        raise ExportError(msg) from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)
