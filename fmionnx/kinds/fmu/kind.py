"""FMU components (FMI 2.0 and 3.0, co-simulation and model exchange).

The interface comes from the FMU's ``modelDescription.xml``, parsed by fmpy after a strict
safety check (:mod:`fmionnx.core.xmlsafe`). How variables become ports is in
:mod:`fmionnx.kinds.fmu.ports`; the facts this kind writes are listed in
:data:`FACT_KEYS` and in ``docs/components.md``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.types import Component, ComponentInterface, Experiment, KindConfig
from fmionnx.core.xmlsafe import parse_safely
from fmionnx.kinds.base import FILE_HASHED, FMI, Display, KindProblem, RoleDefault
from fmionnx.kinds.cache import cached_interface, file_identity
from fmionnx.kinds.fmu.clocks import clock_facts, clock_problems
from fmionnx.kinds.fmu.description import (
    description_key,
    parse_model_description,
    shared_description,
)
from fmionnx.kinds.fmu.files import (
    MODEL_DESCRIPTION,
    FmuFiles,
    check_model_identifier,
    contained_library,
    identity_file,
    read_fmu_files,
)
from fmionnx.kinds.fmu.ports import SIZES_PREFIX, ports_from_model_description, sizing_facts

if TYPE_CHECKING:  # the runner contract brings numpy: loaded when a runner is made
    from fmionnx.core.runner import Runner, Wiring
    from fmionnx.core.specbase import ComponentSpecBase

#: Facts written by this kind (a key is present only when the FMU states it).
FACT_KEYS = (
    "fmiVersion",
    "modelName",
    "instantiationToken",
    "description",
    "generationTool",
    "generationDateAndTime",
    "interfaceTypes",
    "modelIdentifierCS",
    "modelIdentifierME",
    "modelIdentifierSE",
    "platforms",
    "hasSources",
    "canHandleVariableCommunicationStepSize",
    "canGetAndSetFMUstate",
    "needsExecutionTool",
    "canBeInstantiatedOnlyOncePerProcess",
    "numberOfContinuousStates",
    "numberOfEventIndicators",
    # FMI 3 clocks (:mod:`fmionnx.kinds.fmu.clocks`): `unsupported.<clock name>`, one per clock,
    # and the ports updated only at clock ticks
    "clockedVariables",
    # FMI 3 structural parameters that size array ports (:func:`.ports.sizing_facts`):
    # `sizes.<parameter>`, the ports it sizes
)


#: The binary folders an FMU needs to run on this machine (FMI 2 and FMI 3 names).
PLATFORM_FOLDERS = ("linux64", "x86_64-linux")


@dataclass(frozen=True, slots=True)
class FmuConfig(KindConfig):
    """Resolved settings of an FMU component: the interface type is decided at compile time."""

    kind: str = "fmu"
    interface: Literal["cs", "me"] = "cs"
    solver: Literal["cvode", "euler"] = "cvode"
    tolerance: float | None = None


class FmuKind:
    """Reads FMU interfaces from ``modelDescription.xml`` (via fmpy)."""

    name = "fmu"
    config_type = FmuConfig
    suffixes = (".fmu",)
    summary = "Functional Mock-up Unit (FMI 2.0/3.0, CS/ME)"
    mime_type = "application/x-fmu-sharedlibrary"
    capabilities = frozenset({FMI, FILE_HASHED})
    libraries = ("fmpy",)
    display = Display(
        "FMU",
        'shape=box, style="rounded,filled", fillcolor="#dbeafe", color="#1d4ed8"',
        ("[", "]"),
        "#dbeafe",
    )
    ros2_defaults: Mapping[tuple[str, str], RoleDefault] = {}

    @property
    def spec_model(self) -> type[ComponentSpecBase]:
        """The entry's pydantic model (:mod:`.spec`), loaded on first use."""
        from fmionnx.kinds.fmu.spec import FmuSpec

        return FmuSpec

    def check(
        self, spec: ComponentSpecBase, interface: ComponentInterface
    ) -> tuple[KindProblem, ...]:
        """E016 for an interface type the FMU does not offer; E015 without a binary for here;
        E025 for clocks the model needs; E024 for functions its library lacks."""
        from fmionnx.kinds.fmu.spec import FmuSpec  # pydantic: loaded with the entry

        assert isinstance(spec, FmuSpec)
        problems = []
        offered = (interface.fact("interfaceTypes") or "").split(",")
        wanted = spec.interface
        if wanted is not None and wanted not in offered:
            problems.append(
                KindProblem(
                    codes.INTERFACE_TYPE,
                    f"the FMU does not offer {wanted.upper()} "
                    f"(it offers {', '.join(o.upper() for o in offered if o) or 'nothing'})",
                    "interface",
                )
            )
        platforms = (interface.fact("platforms") or "").split(",")
        if not any(folder in platforms for folder in PLATFORM_FOLDERS):
            has_sources = interface.fact("hasSources") == "true"
            shipped = ", ".join(p for p in platforms if p) or "none"
            hint = (
                f"it ships C sources: `fmionnx build-fmu {spec.path}` compiles it for this machine"
                if has_sources
                else "ask the exporter for a Linux x86-64 binary or a source FMU"
            )
            problems.append(
                KindProblem(
                    codes.NO_BINARY,
                    f"the FMU has no binary for linux x86-64 (it has: {shipped})",
                    "path",
                    hint,
                )
            )
        problems.extend(clock_problems(interface.facts))
        if not problems:
            problems.extend(_missing_functions(interface, self.resolve(spec, interface).interface))
        return tuple(problems)

    def result_aliases(self, component: Component) -> dict[str, str]:
        """A lone FMU's results by variable name (:mod:`.resultnames`)."""
        from fmionnx.kinds.fmu.resultnames import result_aliases

        return result_aliases(component)

    def validate_model(self, path: Path, interface: ComponentInterface) -> tuple[KindProblem, ...]:
        """FMPy's validation and the shared library of each model identifier (loads fmpy)."""
        from fmionnx.kinds.fmu.validation import validate_fmu_model

        return validate_fmu_model(path, interface)

    def resolve(self, spec: ComponentSpecBase, interface: ComponentInterface) -> FmuConfig:
        """Co-simulation when the FMU offers it and the entry does not ask for ME."""
        from fmionnx.kinds.fmu.spec import FmuSpec  # pydantic: loaded with the entry

        assert isinstance(spec, FmuSpec)
        offered = (interface.fact("interfaceTypes") or "cs").split(",")
        chosen = spec.interface or ("cs" if "cs" in offered else "me")
        return FmuConfig(interface=chosen, solver=spec.solver, tolerance=spec.tolerance)

    def repeat_problem(self, component: Component) -> str | None:
        """Co-simulation FMUs that declare ``canGetAndSetFMUstate`` repeat a step by rollback.

        Model exchange is integrated by fmionnx, whose integrator state is not rolled back.
        """
        assert isinstance(component.config, FmuConfig)
        if component.config.interface != "cs":
            return (
                "it runs as model exchange; only co-simulation FMUs repeat a step from a saved "
                "state (FMI getFMUstate/setFMUstate)"
            )
        if component.interface.fact("canGetAndSetFMUstate") != "true":
            return (
                "its model description does not declare canGetAndSetFMUstate, so its state "
                "cannot be saved and restored"
            )
        return None

    def for_workers(self) -> None:
        """A study's worker keeps cleanly ended FMUs loaded: an FMU's unpacked files and loaded
        library serve its next cases (:mod:`.libraries`)."""
        from fmionnx.kinds.fmu.libraries import keep_libraries

        keep_libraries()

    def process_reusable(self, component: Component) -> bool:
        """Not for an FMU that may be instantiated only once per process (FMI 2 and 3
        ``canBeInstantiatedOnlyOncePerProcess``): its next run needs a fresh process."""
        return component.interface.fact("canBeInstantiatedOnlyOncePerProcess") != "true"

    def sized_ports(self, interface: ComponentInterface, name: str) -> tuple[str, ...]:
        """The array ports whose ``<Dimension>`` is the structural parameter ``name`` (the
        ``sizes.<name>`` fact the interface reader wrote)."""
        listed = interface.fact(SIZES_PREFIX + name)
        try:  # a compiled-system file's facts are read back as text: never believed
            ports = json.loads(listed) if listed else []
        except ValueError:
            return ()
        return tuple(p for p in ports if isinstance(p, str)) if isinstance(ports, list) else ()

    def warm_up(self) -> None:
        """Import the runners' modules (fmpy's, ctypes): cheap, and every FMU needs them."""
        import fmionnx.kinds.fmu.runner  # noqa: F401

    def make_runner(self, component: Component, wiring: Wiring) -> Runner:
        """The FMU runner of the component's FMI version and interface type (loads fmpy now)."""
        from fmionnx.kinds.fmu.runner import make_fmu_runner

        return make_fmu_runner(component, wiring.driven)

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the FMU's ports and facts (cached per file identity; ``spec`` is not needed).

        Raises ModelError: E010 missing, E011 folder without model description, E012
        unreadable, E013 FMI 1.0 or unknown version, E017 hostile archive or XML.
        """
        if not path.exists():
            msg = f"`{path}` does not exist"
            raise ModelError(codes.FILE_NOT_FOUND, msg)
        identity_of = identity_file(path)
        if path.is_dir() and not identity_of.is_file():
            read_fmu_files(path)  # raises the folder's error
        key = ("fmu", *file_identity(identity_of))
        return cached_interface(key, path, lambda: _kept_or_loaded(path))


def _missing_functions(interface: ComponentInterface, chosen: str) -> list[KindProblem]:
    """E024 when the library a run would load lacks a function of the chosen interface type."""
    from fmionnx.kinds.fmu.exports import (
        PLATFORM_FOLDER,
        describe_missing,
        function_prefix,
        missing_functions,
    )

    major = int((interface.fact("fmiVersion") or "0").split(".")[0] or 0)
    identifier = interface.fact(f"modelIdentifier{chosen.upper()}")
    if identifier is None:
        return []
    missing = missing_functions(interface.path, major, chosen, identifier)
    if not missing:
        return []
    library = f"binaries/{PLATFORM_FOLDER[major]}/{identifier}.so"
    return [
        KindProblem(
            codes.MISSING_FUNCTION,
            describe_missing(missing, library, function_prefix(interface.path, major, identifier)),
            "path",
            "rebuild the FMU (`fmionnx build-fmu` if it ships sources); a shared library "
            "exports the unprefixed FMI names",
        )
    ]


def _kept_or_loaded(path: Path) -> ComponentInterface:
    """The interface kept in the cache folder for this archive, else read (and kept)."""
    from fmionnx.kinds.fmu.keptinterface import kept_interface

    return kept_interface(path, lambda: load_fmu_interface(path))


def load_fmu_interface(path: Path) -> ComponentInterface:
    """Read the interface without the interface cache (see :meth:`FmuKind.read_interface`).

    The parsed model description goes to :mod:`fmionnx.kinds.fmu.description`, where the
    runners of this FMU find it again.
    """
    files = read_fmu_files(path)
    xml_file = Path(path.name) / MODEL_DESCRIPTION
    root = parse_safely(files.model_description, str(xml_file))
    if root.tag != "fmiModelDescription":
        msg = f"`{xml_file}`: root element is <{root.tag}>, not <fmiModelDescription>"
        raise ModelError(codes.BAD_MODEL, msg)
    version = root.get("fmiVersion") or ""
    if version.startswith("1."):
        msg = f"`{path.name}` is an FMI {version} FMU; fmionnx supports FMI 2.0 and 3.0"
        raise ModelError(
            codes.UNSUPPORTED_MODEL,
            msg,
            hint="export the model as FMI 2.0 or 3.0 (most tools offer both)",
        )
    if version != "2.0" and not version.startswith("3."):
        msg = f"`{path.name}` declares fmiVersion `{version}`; fmionnx supports 2.0 and 3.0"
        raise ModelError(codes.UNSUPPORTED_MODEL, msg)
    key = description_key(path, files.content_hash)
    model_description = shared_description(
        key, lambda: parse_model_description(files.model_description, xml_file)
    )
    _check_libraries(model_description, path, xml_file)
    ports = ports_from_model_description(model_description, xml_file, root)
    clocks = clock_facts(root, frozenset(p.name for p in ports))
    return ComponentInterface(
        kind="fmu",
        path=path,
        ports=ports,
        facts=_facts(model_description, files) + tuple(clocks) + sizing_facts(model_description),
        default_experiment=_experiment(model_description),
        content_hash=files.content_hash,
    )


def _check_libraries(md: Any, path: Path, xml_file: Path) -> None:
    """E017 when a model identifier would make the runner load a library outside the FMU."""
    for element in (md.coSimulation, md.modelExchange, getattr(md, "scheduledExecution", None)):
        if element is None:
            continue
        try:
            if path.is_dir():
                contained_library(path, element.modelIdentifier)
            else:
                check_model_identifier(element.modelIdentifier)
        except ModelError as exc:
            raise ModelError(exc.code, f"`{xml_file}`: {exc}", hint=exc.hint) from None


def _flag(value: object) -> str:
    return "true" if value else "false"


def _facts(md: Any, files: FmuFiles) -> tuple[tuple[str, str], ...]:
    facts: dict[str, str] = {}

    def put(key: str, value: object) -> None:
        if value is not None and value != "":
            facts[key] = value if isinstance(value, str) else str(value)

    put("fmiVersion", md.fmiVersion)
    put("modelName", md.modelName)
    put("instantiationToken", md.guid)
    put("description", md.description)
    put("generationTool", md.generationTool)
    put("generationDateAndTime", md.generationDateAndTime)
    interfaces = [
        (short, element)
        for short, element in (
            ("cs", md.coSimulation),
            ("me", md.modelExchange),
            ("se", getattr(md, "scheduledExecution", None)),
        )
        if element is not None
    ]
    put("interfaceTypes", ",".join(short for short, _ in interfaces))
    for short, element in interfaces:
        put(f"modelIdentifier{short.upper()}", element.modelIdentifier)
    put("platforms", ",".join(files.platforms))
    put("hasSources", _flag(files.has_sources))
    if md.coSimulation is not None:
        cs = md.coSimulation
        put(
            "canHandleVariableCommunicationStepSize",
            _flag(cs.canHandleVariableCommunicationStepSize),
        )
    main = md.coSimulation or md.modelExchange or getattr(md, "scheduledExecution", None)
    if main is not None:
        put("canGetAndSetFMUstate", _flag(main.canGetAndSetFMUstate))
        put("needsExecutionTool", _flag(main.needsExecutionTool))
        put("canBeInstantiatedOnlyOncePerProcess", _flag(main.canBeInstantiatedOnlyOncePerProcess))
    put("numberOfContinuousStates", md.numberOfContinuousStates)
    put("numberOfEventIndicators", md.numberOfEventIndicators)
    return tuple(facts.items())


def _float(text: object) -> float | None:
    if text is None:
        return None
    try:
        return float(str(text))
    except ValueError:
        return None


def _experiment(md: Any) -> Experiment | None:
    experiment = md.defaultExperiment
    if experiment is None:
        return None
    return Experiment(
        start=_float(experiment.startTime),
        stop=_float(experiment.stopTime),
        step=_float(experiment.stepSize),
        tolerance=_float(experiment.tolerance),
    )


FMU_KIND = FmuKind()
