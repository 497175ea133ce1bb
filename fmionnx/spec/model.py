"""The raw system-file model: the single source of truth for the format and its JSON Schema.

Both front ends (YAML and SSP) produce a :class:`SystemSpec` plus a
:class:`~fmionnx.spec.sourcemap.SourceMap` that maps every key path to a position in the file
the user wrote, so the compiler can point at ``system.yaml:14:7``.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Annotated, Any, Literal, Union

from pydantic import Field, field_validator, model_validator

from fmionnx.core.specbase import ComponentSpecBase, ScalarLiteral, StrictModel
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.runspec import RunSpec

#: The format versions this release reads (the ``fmionnx:`` key).
SUPPORTED_FORMATS = (1,)


def known_format(value: int) -> int:
    """The ``fmionnx:`` format version of a system or study file, if this release reads it."""
    if value not in SUPPORTED_FORMATS:
        msg = f"format version {value} is not supported; this release reads {SUPPORTED_FORMATS}"
        raise ValueError(msg)
    return value


#: Every registered kind's entry model, discriminated by ``kind`` (built from the kind table,
#: so a new kind is a new entry there and nothing here).
#: (Type checkers see the common base: the union is only known at run time.)
if TYPE_CHECKING:
    ComponentSpec = ComponentSpecBase
else:
    ComponentSpec = Annotated[
        Union[tuple(kind.spec_model for kind in COMPONENT_KINDS.values())],  # noqa: UP007
        Field(discriminator="kind"),
    ]

ARROW = "->"
#: Names of components and of system inputs: dotted identifiers (``sub.gain``, ``sub.k_in``).
#: The first character of each part is an ASCII letter or ``_``; the others may be any
#: letter (``gäin``), as Python's ``\w`` has always let them be: a bug hunt read the old
#: message ("must start with a letter") as refusing the letter ``ä`` for no reason.
DOTTED_NAME = re.compile(r"[A-Za-z_][\w-]*(\.[A-Za-z_][\w-]*)*")
#: The name of a system (the JSON Schema carries it as a pattern).
SYSTEM_NAME_PATTERN = r"^[A-Za-z_][\w-]*$"
#: What each pattern of the schema means, for an error message (pydantic would show the
#: regular expression).
PATTERN_MEANINGS = {
    SYSTEM_NAME_PATTERN: "a name: an ASCII letter or `_`, then letters, digits, `_` or `-` "
    "(no spaces)"
}


class InvalidKeyError(ValueError):
    """A mapping's key is not a valid name; ``key`` lets the error point at that key."""

    def __init__(self, message: str, key: str) -> None:
        super().__init__(message)
        self.key = key


class ConnectionSpec(StrictModel):
    """Long form of a connection, for the options the one-line form cannot carry."""

    from_: str = Field(alias="from", description="Source endpoint `component.port[index]`.")
    to: str = Field(description="Destination endpoint `component.port[index]`.")
    factor: float = Field(default=1.0, description="Linear transformation: y = factor*x + offset.")
    offset: float = Field(default=0.0, description="Linear transformation offset.")
    convert_units: bool = Field(
        default=True,
        description="Convert between the ends' units (km/h -> m/s) before `factor`/`offset`. "
        "`false` (SSP `suppressUnitConversion`): `factor`/`offset` are the whole "
        "transformation.",
    )

    model_config = StrictModel.model_config | {"populate_by_name": True, "allow_inf_nan": False}


def split_connection(text: str) -> tuple[str, str] | None:
    """Split ``"a.b -> c.d"`` into its two endpoint texts, or None without exactly one arrow.

    An arrow inside a quoted port name (``t."a->b"``, see ``ENDPOINT_RE``) is part of the name.
    Unbalanced quotes quote nothing: the endpoint with the stray quote is then the error.
    """
    balanced = text.count('"') % 2 == 0
    arrows = [
        at
        for at in range(len(text))
        if text.startswith(ARROW, at) and (not balanced or text.count('"', 0, at) % 2 == 0)
    ]
    if len(arrows) != 1:
        return None
    (at,) = arrows
    return text[:at].strip(), text[at + len(ARROW) :].strip()


class InputTargetSpec(StrictModel):
    """A port a system input sets, with the transformation on the way."""

    to: str = Field(description="Parameter or input `component.port` the value goes to.")
    factor: float = Field(default=1.0, description="The port gets factor*value + offset.")
    offset: float = Field(default=0.0, description="Offset of the transformation.")

    model_config = StrictModel.model_config | {"allow_inf_nan": False}


class SystemInputSpec(StrictModel):
    """A named input of the system: ``--param NAME=value`` sets every port it reaches."""

    to: list[str | InputTargetSpec] = Field(
        description="Parameters or inputs (`component.port`, or `{to, factor, offset}`) the "
        "value is set on; empty only for an input that holds a `value` of its own.",
    )
    value: ScalarLiteral | None = Field(
        default=None,
        description="The value it holds without `--param` (an SSP top-level connector bound to "
        "a value and connected to nothing keeps it here). Unset: the ports keep their own.",
    )
    description: str = ""

    @model_validator(mode="after")
    def _reaches_something(self) -> SystemInputSpec:
        if not self.to and self.value is None:
            msg = "a system input without `to` targets must hold a `value`"
            raise ValueError(msg)
        return self


class MarksSpec(StrictModel):
    """Marks on a time plot where a discrete signal changes (a controller's state, a mode)."""

    of: str = Field(
        description="A scalar signal (`tracker.state`): a line wherever its value changes."
    )
    labels: dict[int, str] = Field(
        default_factory=dict,
        description="What each value means, written at the mark (`{2: turn left}`); other "
        "values are shown as `signal = value`.",
    )


class PlotSpec(StrictModel):
    """A plot written by ``fmionnx run``: an x-y trajectory or signals over time."""

    xy: tuple[str, str] | None = Field(
        default=None, description="Two signals plotted against each other (x, y)."
    )
    y: list[str] | None = Field(default=None, description="Signals plotted over time.")
    over: str | None = Field(
        default=None,
        description="What an xy plot draws underneath: `world.expected_path` (the path file "
        "next to the component's model, over its map when it has one) or `world.map` (the "
        "scene's fixed landmarks: sites, walls, sign boards in their colours).",
    )
    title: str | None = Field(
        default=None,
        description="Title of the figure; the file is named after it (`Trajectory A -> B`: "
        "`trajectory-a-b.png`).",
    )
    file: str | None = Field(
        default=None,
        description="Output file name inside the output folder, a plain name without folders "
        "(default: derived from the title, else from the signals).",
    )
    marks: MarksSpec | None = Field(
        default=None,
        description="A time plot only: a vertical line, labelled, at each change of a discrete "
        "signal (`{of: tracker.state, labels: {1: sign seen, 2: turn left}}`).",
    )

    @model_validator(mode="after")
    def _one_kind(self) -> PlotSpec:
        if (self.xy is None) == (self.y is None):
            msg = "a plot needs exactly one of `xy` or `y`"
            raise ValueError(msg)
        return self


class CheckSpec(StrictModel):
    """A statement about the run's results that ``fmionnx run`` evaluates (docs/checks.md)."""

    name: str | None = Field(
        default=None,
        min_length=1,
        description="Name in the checks table and run.json (default: the expression).",
    )
    expect: str = Field(
        min_length=1,
        description="`measure <comparison> bound`, e.g. "
        "`abs(final(tracker.v)) < 0.01` or "
        "`max(deviation(odometry.posX, odometry.posY, from=world.expected_path)) < 0.3`.",
    )


class QosSpec(StrictModel):
    """A ROS 2 QoS profile."""

    reliability: Literal["reliable", "best_effort"] = "reliable"
    durability: Literal["volatile", "transient_local"] = "volatile"
    depth: int = Field(default=10, ge=1)


class TopicSpec(StrictModel):
    """Where a port goes on ROS 2: topic, message type, field, QoS."""

    topic: str
    type: str | None = Field(default=None, description="e.g. `geometry_msgs/msg/Twist`.")
    field: str | Annotated[list[str], Field(min_length=1)] | None = Field(
        default=None,
        description="Field path inside the message, or one path per element of an array port "
        "(e.g. `[pose.pose.orientation.w, pose.pose.orientation.x, ...]`).",
    )
    qos: str | QosSpec | None = Field(
        default=None, description="`default`, `sensor_data` or an explicit profile."
    )


class Ros2Spec(StrictModel):
    """The ``ros2:`` section: only what differs from the defaults."""

    namespace: str = Field(default="", description="Namespace of every node, e.g. `/robot1`.")
    distro: Literal["humble", "iron", "jazzy", "kilted"] = Field(
        default="jazzy",
        description="ROS 2 distribution whose message definitions and discovery format to use "
        "(`--ros-distro` overrides it).",
    )
    nodes: dict[str, str] = Field(
        default_factory=dict, description="Node name per component (default: the component name)."
    )
    topics: dict[str, str | TopicSpec] = Field(
        default_factory=dict,
        description="Topic per output port `component.port`; a string may name a field "
        "(`/cmd_vel.linear.x`).",
    )
    qos: dict[str, str | QosSpec] = Field(
        default_factory=dict, description="QoS per topic name or per `component.port`."
    )


class SystemSpec(StrictModel):
    """A whole system file."""

    fmionnx: int = Field(description="Format version of this file; this release reads 1.")
    name: str = Field(pattern=SYSTEM_NAME_PATTERN, description="Name of the system.")
    description: str = ""
    run: RunSpec = Field(default_factory=RunSpec)
    components: dict[str, ComponentSpec] = Field(
        description="Components by name (letters, digits, `_`, `-`)."
    )
    connections: list[str | ConnectionSpec] = Field(
        default_factory=list,
        description="`src.port[i] -> dst.port[j]`, or the long form with `from`/`to`.",
    )
    inputs: dict[str, SystemInputSpec] = Field(
        default_factory=dict,
        description="Named inputs of the system (an SSP system's open input and parameter "
        "connectors): `fmionnx run --param NAME=value` sets the ports each reaches.",
    )
    record: list[str] | None = Field(
        default=None,
        description="Signals written to results.csv (default: every connected output, "
        "images excepted).",
    )
    plots: list[PlotSpec] = Field(default_factory=list)
    checks: list[CheckSpec] = Field(
        default_factory=list,
        description="Statements about the results that `fmionnx run` evaluates; a failed check "
        "makes it exit 1.",
    )
    ros2: Ros2Spec | None = None

    @field_validator("fmionnx")
    @classmethod
    def _known_format(cls, value: int) -> int:
        return known_format(value)

    @field_validator("inputs")
    @classmethod
    def _input_names(cls, value: dict[str, Any]) -> dict[str, Any]:
        for name in value:
            if not DOTTED_NAME.fullmatch(name):
                msg = (
                    f"system input name `{name}` must start with an ASCII letter or `_` and "
                    "contain only letters, digits, `_`, `-` (and `.` between parts of a "
                    "nested name, each starting so)"
                )
                raise InvalidKeyError(msg, name)
        return value

    @field_validator("components")
    @classmethod
    def _component_names(cls, value: dict[str, Any]) -> dict[str, Any]:
        for name in value:
            if not DOTTED_NAME.fullmatch(name):
                msg = (
                    f"component name `{name}` must start with an ASCII letter or `_` and "
                    "contain only letters, digits, `_`, `-` (and `.` between parts of a "
                    "nested name, each starting so)"
                )
                raise InvalidKeyError(msg, name)
        return value


def json_schema() -> dict[str, Any]:
    """The JSON Schema of the system file (written to ``schemas/system.schema.json``)."""
    schema = SystemSpec.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = "https://fmionnx.dev/schemas/system.schema.json"
    schema["title"] = "fmionnx system file"
    return schema
