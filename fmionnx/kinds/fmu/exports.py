"""Does the FMU's shared library export every function its interface type needs? (E024)

A binary exports the FMI functions under their unprefixed names (a prefix is for static
linking of source code only), all of those its interface type needs (:data:`REQUIRED`). fmpy
binds them when it loads the library, so a missing one used to surface as a Python
``AttributeError: undefined symbol`` when a run instantiated the FMU. This module names the missing
functions before anything is loaded: the library is read as data (:mod:`.elfsymbols`), never
``dlopen``-ed, so compiling a system runs no supplier code.

A library that cannot be read as ELF is left to the run (it may be for another machine and
E015 already says so); what is checked is the library a run on this machine would load.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.core.archive import CORRUPT_ZIP_ERRORS, check_archive, open_zip
from fmionnx.kinds.cache import BoundedCache, file_identity
from fmionnx.kinds.fmu.elfsymbols import NotElfError, exported_symbols
from fmionnx.kinds.fmu.files import identity_file

#: Largest library read for its symbols; a bigger one is not checked here (the run loads it).
MAX_LIBRARY_BYTES = 1024**3

#: The binary folder of this machine per FMI major version.
PLATFORM_FOLDER = {2: "linux64", 3: "x86_64-linux"}

_FMI2_COMMON = (
    "GetTypesPlatform GetVersion SetDebugLogging Instantiate FreeInstance SetupExperiment "
    "EnterInitializationMode ExitInitializationMode Terminate Reset GetReal GetInteger "
    "GetBoolean GetString SetReal SetInteger SetBoolean SetString GetFMUstate SetFMUstate "
    "FreeFMUstate SerializedFMUstateSize SerializeFMUstate DeSerializeFMUstate "
    "GetDirectionalDerivative"
)
_FMI2_ME = (
    "EnterEventMode NewDiscreteStates EnterContinuousTimeMode CompletedIntegratorStep SetTime "
    "SetContinuousStates GetDerivatives GetEventIndicators GetContinuousStates "
    "GetNominalsOfContinuousStates"
)
_FMI2_CS = (
    "SetRealInputDerivatives GetRealOutputDerivatives DoStep CancelStep GetStatus "
    "GetRealStatus GetIntegerStatus GetBooleanStatus GetStringStatus"
)
_FMI3_TYPES = (
    "Float32 Float64 Int8 UInt8 Int16 UInt16 Int32 UInt32 Int64 UInt64 Boolean String Binary"
)
_FMI3_COMMON = (
    "GetVersion SetDebugLogging FreeInstance EnterInitializationMode ExitInitializationMode "
    "EnterEventMode Terminate Reset "
    + " ".join(f"Get{t} Set{t}" for t in _FMI3_TYPES.split())
    + " GetNumberOfVariableDependencies GetVariableDependencies GetFMUState SetFMUState "
    "FreeFMUState SerializedFMUStateSize SerializeFMUState DeserializeFMUState "
    "GetDirectionalDerivative GetAdjointDerivative EnterConfigurationMode "
    "ExitConfigurationMode"
)
#: Clock functions: FMI 3 requires them of co-simulation and model exchange too (3.0, 2.2).
_FMI3_CLOCKS = (
    "GetClock SetClock GetIntervalDecimal GetIntervalFraction GetShiftDecimal GetShiftFraction "
    "SetIntervalDecimal SetIntervalFraction SetShiftDecimal SetShiftFraction "
    "EvaluateDiscreteStates UpdateDiscreteStates"
)
_FMI3_ME = (
    "InstantiateModelExchange EnterContinuousTimeMode CompletedIntegratorStep SetTime "
    "SetContinuousStates GetContinuousStateDerivatives GetEventIndicators GetContinuousStates "
    "GetNominalsOfContinuousStates GetNumberOfEventIndicators GetNumberOfContinuousStates"
)
_FMI3_CS = "InstantiateCoSimulation EnterStepMode GetOutputDerivatives DoStep"
_FMI3_SE = "InstantiateScheduledExecution ActivateModelPartition"


def _names(prefix: str, *groups: str) -> tuple[str, ...]:
    return tuple(prefix + name for group in groups for name in group.split())


#: Every function of the FMI 3 API, as ``fmi3Functions.h`` declares it.
_FMI3_ALL = _names("fmi3", _FMI3_COMMON, _FMI3_CLOCKS, _FMI3_ME, _FMI3_CS, _FMI3_SE)

#: The functions a binary must export, per (FMI major version, interface type).
#:
#: FMI 2: the common functions and those of the interface type (FMI 2.0, 2.1.2). FMI 3: the
#: whole API for either type, because the loader binds every function the header declares when
#: it opens the library (fmpy's ``FMU3Slave`` and ``FMU3Model`` do; a library without
#: ``fmi3ActivateModelPartition`` cannot even be opened for co-simulation), and exporters such
#: as the Reference FMUs export them all, unsupported ones answering ``fmi3Error``.
REQUIRED: dict[tuple[int, str], tuple[str, ...]] = {
    (2, "cs"): _names("fmi2", _FMI2_COMMON, _FMI2_CS),
    (2, "me"): _names("fmi2", _FMI2_COMMON, _FMI2_ME),
    (3, "cs"): _FMI3_ALL,
    (3, "me"): _FMI3_ALL,
}

_SYMBOLS: BoundedCache[tuple[str, int, int, str], frozenset[str]] = BoundedCache(64)


def _library_bytes(path: Path, member: str) -> bytes | None:
    """The library ``member`` of the FMU at ``path`` (folder or archive), None when absent."""
    if path.is_dir():
        file = path / member
        if not file.is_file() or file.stat().st_size > MAX_LIBRARY_BYTES:
            return None
        return file.read_bytes()
    with open_zip(path) as archive:
        check_archive(archive)
        try:
            info = archive.getinfo(member)
        except KeyError:
            return None
        if info.file_size > MAX_LIBRARY_BYTES:
            return None
        try:
            return archive.read(info)
        except CORRUPT_ZIP_ERRORS:  # not readable here: the run's unpacking reports it (E012)
            return None


def _exports(path: Path, member: str) -> frozenset[str] | None:
    library = path / member
    # a folder's library changes without its model description: key by the library itself
    identity = library if path.is_dir() and library.is_file() else identity_file(path)
    key = (*file_identity(identity), member)
    empty: frozenset[str] = frozenset({""})  # "not readable", distinct from "exports nothing"

    def load() -> frozenset[str]:
        data = _library_bytes(path, member)
        if data is None:
            return empty
        try:
            return exported_symbols(data)
        except NotElfError:
            return empty

    found = _SYMBOLS.get_or_load(key, load)
    return None if found == empty else found


def missing_functions(
    path: Path, major: int, interface_type: str, identifier: str
) -> tuple[str, ...] | None:
    """The required functions the library for here does not export, in the standard's order.

    None when there is no readable library for this machine to check (E015 covers a missing
    one; a damaged one fails when the run loads it).
    """
    folder = PLATFORM_FOLDER.get(major)
    required = REQUIRED.get((major, interface_type))
    if folder is None or required is None:
        return None
    exported = _exports(path, f"binaries/{folder}/{identifier}.so")
    if exported is None:
        return None
    return tuple(name for name in required if name not in exported)


def function_prefix(path: Path, major: int, identifier: str) -> str | None:
    """The prefix the library puts before the FMI names (``Model_`` of ``Model_fmi3DoStep``).

    None when the library exports no prefixed FMI name. A library built from source without
    the standard's rule (FMI 3: ``FMI3_OVERRIDE_FUNCTION_PREFIX``) exports only such names.
    """
    folder = PLATFORM_FOLDER.get(major)
    exported = _exports(path, f"binaries/{folder}/{identifier}.so") if folder else None
    marker = f"fmi{major}"
    for name in sorted(exported or ()):
        at = name.find(marker)
        if at > 0 and name[at:] in REQUIRED[major, "cs"] + REQUIRED[major, "me"]:
            return name[:at]
    return None


def describe_missing(missing: tuple[str, ...], library: str, prefix: str | None = None) -> str:
    """The E024 message: every missing name, at most a dozen quoted, and a prefix if found."""
    shown = ", ".join(f"`{name}`" for name in missing[:12])
    more = f" and {len(missing) - 12} more" if len(missing) > 12 else ""
    text = f"`{library}` does not export {shown}{more}, which the FMI standard requires"
    if prefix is not None:
        text += (
            f"; it exports them prefixed with `{prefix}` (compiled from source as for static "
            "linking, without the standard's rule that a shared library has unprefixed names)"
        )
    return text


def clear_exports() -> None:
    """Forget every library read (tests)."""
    _SYMBOLS.clear()
