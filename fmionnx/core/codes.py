"""Every diagnostic code, as a symbol (in the spirit of mypy's ``errorcodes.py``).

Call sites name a code by its symbol (``bag.emit(codes.UNKNOWN_PORT, ...)``): a misspelt
code fails at import, not when the diagnostic is made. Codes are never renumbered; retired
codes stay. Ranges: E00x syntax/schema, E01x model files, E02x endpoints, E03x connection
checks, E04x run settings and parameters, E05x graph, E06x ROS 2, E07x SSP, E08x interface
lock, E09x checks, E1xx studies. ``tests/architecture/test_codes.py`` refuses a bare code
string anywhere else in the package.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class Severity(enum.IntEnum):
    """How bad a finding is; ordered so that ``max()`` gives the worst."""

    INFO = 0
    WARNING = 1
    ERROR = 2

    @property
    def label(self) -> str:
        """Lower-case name used in text output (``error``, ``warning``, ``info``)."""
        return self.name.lower()


@dataclass(frozen=True, slots=True)
class ErrorCode:
    """One entry of the stable code table (in the spirit of ``mypy/errorcodes.py``)."""

    code: str
    name: str
    severity: Severity
    category: str
    description: str


def _codes(*entries: ErrorCode) -> dict[str, ErrorCode]:
    table: dict[str, ErrorCode] = {}
    for entry in entries:
        if entry.code in table:
            msg = f"duplicate diagnostic code {entry.code}"
            raise ValueError(msg)
        table[entry.code] = entry
    return table


_E = Severity.ERROR
_W = Severity.WARNING
_I = Severity.INFO

#: The stable table of every diagnostic code. Codes are never renumbered; retired codes stay.
#: Ranges: E00x syntax/schema, E01x model files, E02x endpoints, E03x connection checks,
#: E04x run settings and parameters, E05x graph, E06x ROS 2, E07x SSP, E08x interface lock,
#: E09x checks.
# --- system file syntax and schema
SYNTAX = ErrorCode("E001", "syntax", _E, "syntax", "The system file is not well-formed YAML/XML.")
UNKNOWN_KEY = ErrorCode(
    "E002", "unknown-key", _E, "schema", "A key that the format does not define."
)
INVALID_VALUE = ErrorCode(
    "E003", "invalid-value", _E, "schema", "A value of the wrong type or out of range."
)
MISSING_KEY = ErrorCode("E004", "missing-key", _E, "schema", "A required key is missing.")
FORMAT_VERSION = ErrorCode(
    "E005", "format-version", _E, "schema", "Unsupported `fmionnx:` format version."
)
ENCODING = ErrorCode("E006", "encoding", _E, "syntax", "The file is not UTF-8 text.")
DUPLICATE_KEY = ErrorCode(
    "E007",
    "duplicate-key",
    _E,
    "syntax",
    "A key appears twice in one mapping, or a name twice in one SSP system.",
)
RESOURCE_LIMIT = ErrorCode(
    "E008",
    "resource-limit",
    _E,
    "model",
    "A model or file is larger than a resource limit (array elements, file size).",
)
# --- model files
FILE_NOT_FOUND = ErrorCode(
    "E010", "file-not-found", _E, "model", "A referenced file does not exist."
)
NOT_A_FILE = ErrorCode(
    "E011", "not-a-file", _E, "model", "A directory or special file where a file is expected."
)
BAD_MODEL = ErrorCode(
    "E012",
    "bad-model",
    _E,
    "model",
    "The model file cannot be read (corrupt archive, bad XML, bad protobuf).",
)
UNSUPPORTED_MODEL = ErrorCode(
    "E013",
    "unsupported-model",
    _E,
    "model",
    "A model version or feature fmionnx does not support.",
)
UNKNOWN_KIND = ErrorCode(
    "E014", "unknown-kind", _E, "schema", "A component kind that is not registered."
)
NO_BINARY = ErrorCode(
    "E015",
    "no-binary",
    _E,
    "model",
    "The FMU has no binary for this platform (and no sources to build).",
)
INTERFACE_TYPE = ErrorCode(
    "E016",
    "interface-type",
    _E,
    "model",
    "The FMU does not offer the requested interface type (CS/ME).",
)
UNSAFE_ARCHIVE = ErrorCode(
    "E017",
    "unsafe-archive",
    _E,
    "model",
    "An archive or model file that reaches outside its place, or an excessive archive.",
)
UNKNOWN_OPTION = ErrorCode(
    "E018",
    "unknown-option",
    _E,
    "schema",
    "An option that does not apply to this component kind.",
)
INVALID_MODEL = ErrorCode(
    "E019",
    "invalid-model",
    _E,
    "model",
    "A model fails its format's own validation (FMPy, the ONNX checker and shape inference).",
)
# --- endpoints
UNKNOWN_COMPONENT = ErrorCode(
    "E020",
    "unknown-component",
    _E,
    "endpoint",
    "A connection names a component that does not exist.",
)
UNKNOWN_PORT = ErrorCode(
    "E021",
    "unknown-port",
    _E,
    "endpoint",
    "A connection names a port the component does not have.",
)
BAD_INDEX = ErrorCode(
    "E022",
    "bad-index",
    _E,
    "endpoint",
    "An element index that is out of range or on a scalar port.",
)
BAD_ENDPOINT = ErrorCode(
    "E023",
    "bad-endpoint",
    _E,
    "endpoint",
    "An endpoint that is not of the form `component.port[index]`.",
)
MISSING_FUNCTION = ErrorCode(
    "E024",
    "missing-function",
    _E,
    "model",
    "An FMU's shared library does not export a function its interface type requires.",
)
UNSUPPORTED_VARIABLE = ErrorCode(
    "E025",
    "unsupported-variable",
    _E,
    "model",
    "A system uses a model variable in a way fmionnx does not support: an FMI 3 clock (named "
    "in an endpoint, or needed by the model), a string or binary port connected or recorded, "
    "an image recorded.",
)
# --- connection checks
CAUSALITY = ErrorCode(
    "E030",
    "causality",
    _E,
    "connection",
    "A connection must go from an output to an input or parameter.",
)
DTYPE = ErrorCode(
    "E031", "dtype", _E, "connection", "Element types on both ends cannot be converted."
)
SHAPE = ErrorCode("E032", "shape", _E, "connection", "Element counts on both ends differ.")
UNIT = ErrorCode(
    "E033",
    "unit",
    _E,
    "connection",
    "The ends' units measure different quantities, or differ and cannot be compared.",
)
MULTIPLE_DRIVERS = ErrorCode(
    "E034",
    "multiple-drivers",
    _E,
    "connection",
    "An input is driven by more than one connection.",
)
ALGEBRAIC_LOOP = ErrorCode(
    "E035", "algebraic-loop", _E, "graph", "A cycle through direct-feedthrough ports."
)
SELF_CONNECTION = ErrorCode(
    "E036", "self-connection", _E, "connection", "A connection from a port to itself."
)
UNCONNECTED_INPUT = ErrorCode(
    "W030",
    "unconnected-input",
    _W,
    "connection",
    "An input nobody drives: its start value is used.",
)
LOSSY_CONVERSION = ErrorCode(
    "W031",
    "lossy-conversion",
    _W,
    "connection",
    "A conversion that may lose precision or range.",
)
UNIT_CONVERSION = ErrorCode(
    "I033",
    "unit-conversion",
    _I,
    "connection",
    "Units of the same quantity that differ: the connection converts (or, suppressed, says "
    "it does not).",
)
UNIT_SUSPICIOUS = ErrorCode(
    "W033",
    "unit-suspicious",
    _W,
    "connection",
    "Values pass between different quantities (conversion suppressed), or a factor that "
    "repeats the automatic unit conversion.",
)
# --- run settings and parameters
RUN_SETTINGS = ErrorCode(
    "E040", "run-settings", _E, "run", "Start, stop or step time are inconsistent."
)
PERIOD = ErrorCode(
    "E041", "period", _E, "run", "A component period is not a whole multiple of the base step."
)
UNKNOWN_PARAMETER = ErrorCode(
    "E042",
    "unknown-parameter",
    _E,
    "parameter",
    "A parameter or start value the model does not have.",
)
PARAMETER_VALUE = ErrorCode(
    "E043",
    "parameter-value",
    _E,
    "parameter",
    "A parameter value of the wrong type or shape, NaN, or outside the variable's bounds.",
)
PARAMETER_CAUSALITY = ErrorCode(
    "E044",
    "parameter-causality",
    _E,
    "parameter",
    "A value set on a variable that may not be set.",
)
PLOT = ErrorCode(
    "E045",
    "plot",
    _E,
    "run",
    "A plot names a signal, reference or file that does not exist or is not allowed.",
)
PLOT_SIGNAL = ErrorCode(
    "E046",
    "plot-signal",
    _E,
    "run",
    "A plotted signal that cannot be drawn: an image, a string, a parameter, an array "
    "on an xy axis.",
)
OUTPUT_INTERVAL = ErrorCode(
    "E047",
    "output-interval",
    _E,
    "run",
    "The output interval is not a whole multiple of the base step.",
)
LONG_RUN = ErrorCode(
    "W040", "long-run", _W, "run", "A run of more than 10^8 base steps (it may take hours)."
)
# --- graph
DUPLICATE_COMPONENT = ErrorCode(
    "E050", "duplicate-component", _E, "graph", "Two components share a name."
)
ISOLATED_COMPONENT = ErrorCode(
    "W050", "isolated-component", _W, "graph", "A component with no connections at all."
)
LOOP_ROLLBACK = ErrorCode(
    "E051",
    "loop-rollback",
    _E,
    "graph",
    "A component of an algebraic loop to iterate cannot repeat a step from a saved state.",
)
LOOP_PERIOD = ErrorCode(
    "E052",
    "loop-period",
    _E,
    "graph",
    "The components of an algebraic loop to iterate do not share one period.",
)
LOOP_VALUES = ErrorCode(
    "E053",
    "loop-values",
    _E,
    "graph",
    "An algebraic loop to iterate exchanges values that are not floating-point numbers.",
)
# --- ROS 2 (issue: ROS 2 mode)
ROS2_TYPE = ErrorCode("E060", "ros2-type", _E, "ros2", "Unknown ROS 2 message type.")
ROS2_FIELD = ErrorCode(
    "E061",
    "ros2-field",
    _E,
    "ros2",
    "A message field that does not exist or does not fit the port.",
)
ROS2_NAME = ErrorCode(
    "E062", "ros2-name", _E, "ros2", "A node or topic name that ROS 2 does not allow."
)
ROS2_QOS = ErrorCode("E063", "ros2-qos", _E, "ros2", "Unknown or inconsistent QoS profile.")
ROS2_UNMAPPED = ErrorCode(
    "E064", "ros2-unmapped", _E, "ros2", "A port that cannot be mapped onto a ROS 2 topic."
)
ROS2_REFERENCE = ErrorCode(
    "E065",
    "ros2-reference",
    _E,
    "ros2",
    "The ros2 section names a component or port that does not exist.",
)
ROS2_LOSSY_FIELD = ErrorCode(
    "W060",
    "ros2-lossy-field",
    _W,
    "ros2",
    "A message field that cannot hold every value of the port mapped onto it.",
)
# --- SSP (issue: SSP)
SSP_SCHEMA = ErrorCode(
    "E070", "ssp-schema", _E, "ssp", "The SSD does not validate against the SSP XSD."
)
SSP_UNSUPPORTED = ErrorCode(
    "E071", "ssp-unsupported", _E, "ssp", "An SSP feature fmionnx does not support yet."
)
SSP_REFERENCE = ErrorCode(
    "E072",
    "ssp-reference",
    _E,
    "ssp",
    "An SSP element references something that does not exist.",
)
SSP_JUNCTION = ErrorCode(
    "E073",
    "ssp-junction",
    _E,
    "ssp",
    "System connectors that cannot be flattened (driven twice, or in a cycle).",
)
SSP_IGNORED = ErrorCode(
    "W070", "ssp-ignored", _W, "ssp", "An SSP element that fmionnx reads but ignores."
)
SSP_LAYOUT = ErrorCode(
    "I070", "ssp-layout", _I, "ssp", "The SSP diagram layout (geometry) is not used."
)
# --- interface lock (issue: CI)
LOCK_INTERFACE_CHANGED = ErrorCode(
    "E080",
    "lock-interface-changed",
    _E,
    "lock",
    "A model's interface differs from the lock file.",
)
LOCK_MISSING = ErrorCode(
    "E081", "lock-missing", _E, "lock", "No lock file, or a component missing from it."
)
LOCK_INVALID = ErrorCode("E082", "lock-invalid", _E, "lock", "The lock file cannot be read.")
LOCK_BINARY_CHANGED = ErrorCode(
    "I080", "lock-binary-changed", _I, "lock", "The model file changed, its interface did not."
)
# --- checks (issue #16)
CHECK_SYNTAX = ErrorCode(
    "E090", "check-syntax", _E, "checks", "A check expression that does not parse."
)
CHECK_SIGNAL = ErrorCode(
    "E091", "check-signal", _E, "checks", "A check names a signal that cannot be measured."
)
CHECK_REFERENCE = ErrorCode(
    "E092",
    "check-reference",
    _E,
    "checks",
    "A check names a site, component or expected path that does not exist.",
)
CHECK_MEANING = ErrorCode(
    "E093", "check-meaning", _E, "checks", "A check expression that parses but means nothing."
)
DUPLICATE_CHECK = ErrorCode("E094", "duplicate-check", _E, "checks", "Two checks share a name.")
# --- studies (issue #15): `fmionnx sweep`
STUDY_FILE = ErrorCode(
    "E100", "study-file", _E, "study", "A study file that is missing or not a study."
)
STUDY_SYSTEM = ErrorCode(
    "E101",
    "study-system",
    _E,
    "study",
    "The study's system file is missing or does not compile.",
)
STUDY_TARGET = ErrorCode(
    "E102",
    "study-target",
    _E,
    "study",
    "A study target that names no parameter, system input, run setting or component.",
)
STUDY_VALUES = ErrorCode(
    "E103", "study-values", _E, "study", "Values that do not fit their target, or no sampling."
)
STUDY_METRIC = ErrorCode(
    "E104", "study-metric", _E, "study", "A metric named like one of the system's checks."
)
STUDY_OBJECTIVE = ErrorCode(
    "E105", "study-objective", _E, "study", "An objective that names no metric."
)
STUDY_SIZE = ErrorCode("E106", "study-size", _E, "study", "A study of more than a million cases.")
STUDY_SETTING = ErrorCode(
    "E107",
    "study-setting",
    _E,
    "study",
    "A study target that names no parameter or setting of its component.",
)
STUDY_SETTING_VALUE = ErrorCode(
    "E108",
    "study-setting-value",
    _E,
    "study",
    "A value that a component's setting refuses (a signal's or a scene's).",
)


STUDY_COLUMN = ErrorCode(
    "E109",
    "study-column",
    _E,
    "study",
    "A target or metric name the study's table cannot take as a column (one of its own "
    "columns, another's name, not a short plain name).",
)
STUDY_PLOTS = ErrorCode(
    "W100",
    "study-plots",
    _W,
    "study",
    "More metrics than the study's summary plots draw (the table has them all).",
)


#: The table of every code, by its code string (``E035``).
CODES: dict[str, ErrorCode] = _codes(
    SYNTAX,
    UNKNOWN_KEY,
    INVALID_VALUE,
    MISSING_KEY,
    FORMAT_VERSION,
    ENCODING,
    DUPLICATE_KEY,
    RESOURCE_LIMIT,
    FILE_NOT_FOUND,
    NOT_A_FILE,
    BAD_MODEL,
    UNSUPPORTED_MODEL,
    UNKNOWN_KIND,
    NO_BINARY,
    INTERFACE_TYPE,
    UNSAFE_ARCHIVE,
    UNKNOWN_OPTION,
    INVALID_MODEL,
    UNKNOWN_COMPONENT,
    UNKNOWN_PORT,
    BAD_INDEX,
    BAD_ENDPOINT,
    MISSING_FUNCTION,
    UNSUPPORTED_VARIABLE,
    CAUSALITY,
    DTYPE,
    SHAPE,
    UNIT,
    MULTIPLE_DRIVERS,
    ALGEBRAIC_LOOP,
    SELF_CONNECTION,
    UNCONNECTED_INPUT,
    LOSSY_CONVERSION,
    UNIT_CONVERSION,
    UNIT_SUSPICIOUS,
    RUN_SETTINGS,
    PERIOD,
    UNKNOWN_PARAMETER,
    PARAMETER_VALUE,
    PARAMETER_CAUSALITY,
    PLOT,
    PLOT_SIGNAL,
    OUTPUT_INTERVAL,
    LONG_RUN,
    DUPLICATE_COMPONENT,
    ISOLATED_COMPONENT,
    LOOP_ROLLBACK,
    LOOP_PERIOD,
    LOOP_VALUES,
    ROS2_TYPE,
    ROS2_FIELD,
    ROS2_NAME,
    ROS2_QOS,
    ROS2_UNMAPPED,
    ROS2_REFERENCE,
    ROS2_LOSSY_FIELD,
    SSP_SCHEMA,
    SSP_UNSUPPORTED,
    SSP_REFERENCE,
    SSP_JUNCTION,
    SSP_IGNORED,
    SSP_LAYOUT,
    LOCK_INTERFACE_CHANGED,
    LOCK_MISSING,
    LOCK_INVALID,
    LOCK_BINARY_CHANGED,
    CHECK_SYNTAX,
    CHECK_SIGNAL,
    CHECK_REFERENCE,
    CHECK_MEANING,
    DUPLICATE_CHECK,
    STUDY_FILE,
    STUDY_SYSTEM,
    STUDY_TARGET,
    STUDY_VALUES,
    STUDY_METRIC,
    STUDY_OBJECTIVE,
    STUDY_SIZE,
    STUDY_SETTING,
    STUDY_SETTING_VALUE,
    STUDY_COLUMN,
    STUDY_PLOTS,
)
