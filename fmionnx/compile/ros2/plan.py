"""From a compiled system to ROS 2 nodes and topics, and the compiler checks of ``ros2:``.

Every component except ``external`` ones becomes a node (name: the ``ros2.nodes`` entry or the
component name). Every output that feeds a connection, and every port listed in
``ros2.topics``, is published on a topic; every connection's destination node subscribes to
its source's topic. Defaults need no section:

===========================================  ==========================================
port                                         topic, type, field
===========================================  ==========================================
camera (``uint8[H,W,3]`` or ``[1,H,W,3]``)   ``<node>/<port>``, ``sensor_msgs/msg/Image``
scalar float or bool                         ``<node>/<port>``, ``std_msgs/msg/Float64`` ``data``
scalar integer (``int64`` ...)               ``<node>/<port>``, ``std_msgs/msg/Int64`` ... ``data``
array of floats or bools                     ``<node>/<port>``, ``std_msgs/msg/Float64MultiArray``
array of integers (``int64`` ...)            ``<node>/<port>``, ``std_msgs/msg/Int64MultiArray`` ...
string                                       not published: string connections are E025
output feeding MuJoCo ``cmd_v`` / ``cmd_w``   ``cmd_vel``, ``geometry_msgs/msg/Twist`` ``linear.x`` / ``angular.z``
MuJoCo ``base_pos`` / ``base_quat``          ``odom``, ``nav_msgs/msg/Odometry`` ``pose.pose.position`` / ``.orientation``
===========================================  ==========================================

Integer ports get the std_msgs type of their own width and sign: a ``Float64`` holds integers
only up to 2**53, and lockstep must hand a 64-bit value on bit for bit as the in-process run
does. Floats and bools keep ``Float64`` (exact for both).

Relative names are resolved in ``ros2.namespace``. :func:`build_plan` returns the plan and
every diagnostic (E060..E065, and W060 for an explicit mapping onto a field that cannot hold
every value of its port); :func:`check_ros2` only the diagnostics.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from fmionnx.compile.endpoints import split_endpoint
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.ros2.fields import IMAGE_TYPE, WHOLE, PortField, image_geometry
from fmionnx.compile.ros2.messages import (
    BASE_DTYPE,
    DEFAULT_DISTRO,
    FieldError,
    FieldInfo,
    FieldKind,
    RosDistro,
    message_types,
    normalize_type,
    numeric_leaves,
    resolve_field,
)
from fmionnx.compile.ros2.names import (
    expand_topic,
    namespace_problem,
    node_name_problem,
    sanitize_token,
    topic_problem,
)
from fmionnx.compile.ros2.qos import PROFILES, QosProfile
from fmionnx.compile.ros2.types import NodePlan, Ros2Plan, Subscription, TopicPlan
from fmionnx.compile.typecheck import SIGNIFICAND_BITS, is_lossy
from fmionnx.core import codes
from fmionnx.core.codes import ErrorCode
from fmionnx.core.diagnostics import Diagnostic, Span, did_you_mean, make, one_of, with_article
from fmionnx.core.types import Causality, Component, DType, Port
from fmionnx.kinds.base import SIMULATOR, RoleDefault
from fmionnx.kinds.registry import COMPONENT_KINDS, has_capability

if TYPE_CHECKING:
    from fmionnx.spec.sourcemap import SourceMap

TWIST = "geometry_msgs/msg/Twist"
ODOMETRY = "nav_msgs/msg/Odometry"
FLOAT64 = "std_msgs/msg/Float64"
FLOAT64_ARRAY = "std_msgs/msg/Float64MultiArray"
STRING = "std_msgs/msg/String"
CLOCK_TOPIC = "/clock"
CLOCK_TYPE = "rosgraph_msgs/msg/Clock"


def role_default(kind: str, port: str, causality: Causality) -> RoleDefault | None:
    """The kind's default topic for a well-known port; for an input role, the output feeding
    it gets the topic."""
    found = COMPONENT_KINDS.get(kind)
    return None if found is None else found.ros2_defaults.get((port, causality.value))


@dataclass
class _Draft:
    """A topic being assembled (ports may join from several places)."""

    name: str
    msgtype: str
    publisher: str | None
    fields: list[PortField] = field(default_factory=list)
    qos: QosProfile | None = None
    span: Span | None = None


class _Builder:
    def __init__(
        self, system: CompiledSystem, distro: RosDistro, sources: SourceMap | None
    ) -> None:
        self.system = system
        self.distro = distro
        self.sources = sources
        self.spec = system.ros2
        self.diagnostics: list[Diagnostic] = []
        self.namespace = (self.spec.namespace if self.spec else "") or "/"
        self.node_names: dict[str, str] = {}
        self.drafts: dict[str, _Draft] = {}
        self.port_topics: dict[tuple[str, str], str] = {}
        self.known_types = set(message_types(distro))

    # --- helpers
    def span(self, *path: str | int) -> Span:
        if self.sources is None:
            return Span(self.system.source)
        return self.sources.value(("ros2", *path))

    def key_span(self, *path: str | int) -> Span:
        if self.sources is None:
            return Span(self.system.source)
        return self.sources.key(("ros2", *path))

    def emit(self, code: ErrorCode, message: str, span: Span, hint: str | None = None) -> None:
        self.diagnostics.append(make(code, message, span, hint=hint))

    def component(self, name: str) -> Component | None:
        for component in self.system.components:
            if component.name == name:
                return component
        return None

    # --- stages
    def run(self) -> Ros2Plan | None:
        self.check_namespace()
        self.assign_node_names()
        explicit = self.explicit_topics()
        self.default_topics(explicit)
        self.apply_qos()
        plan = self.finish()
        return None if any(d.code.startswith("E") for d in self.diagnostics) else plan

    def check_namespace(self) -> None:
        problem = namespace_problem(self.namespace)
        if problem is not None:
            self.emit(
                codes.ROS2_NAME,
                f"ros2 namespace `{self.namespace}`: {problem}",
                self.span("namespace"),
            )
            self.namespace = "/"

    def assign_node_names(self) -> None:
        requested = dict(self.spec.nodes) if self.spec else {}
        for component_name in requested:
            if self.component(component_name) is None:
                self.unknown_component(component_name, ("nodes", component_name))
        used: dict[str, str] = {}
        for component in self.system.components:
            name = requested.get(component.name) or sanitize_token(component.name)
            problem = node_name_problem(name)
            if problem is not None:
                self.emit(
                    codes.ROS2_NAME,
                    f"node name `{name}` of component `{component.name}`: {problem}",
                    self.span("nodes", component.name),
                )
            elif name in used and not component.external:
                self.emit(
                    codes.ROS2_NAME,
                    f"node name `{name}` is used by `{used[name]}` and `{component.name}`",
                    self.span("nodes", component.name),
                    hint="give each component its own node name under `ros2.nodes`",
                )
            used.setdefault(name, component.name)
            self.node_names[component.name] = name

    def unknown_component(self, name: str, path: tuple[str | int, ...]) -> None:
        names = [c.name for c in self.system.components]
        self.emit(
            codes.ROS2_REFERENCE,
            f"the ros2 section names component `{name}`, which the system does not have",
            self.key_span(*path),
            hint=did_you_mean(name, names) or one_of(names),
        )

    def parse_endpoint(self, key: str, section: str) -> tuple[Component, Port] | None:
        # As connections are read: the longest component name that prefixes the key, so a
        # dotted port (`body.x`) is found, and a quoted one (`net."input.1"`) too.
        split = split_endpoint(key, {c.name: c for c in self.system.components})
        if split is None or split[2] is not None:
            self.emit(
                codes.ROS2_REFERENCE,
                f"`{key}` in ros2.{section} is not `component.port`",
                self.key_span(section, key),
                hint='a port whose name is no dotted word goes in quotes: `net."input.1"`'
                if split is None
                else "name the whole port: topics carry ports, not their elements",
            )
            return None
        component_name, port_name, _ = split
        component = self.component(component_name)
        if component is None:
            self.unknown_component(component_name, (section, key))
            return None
        port = component.interface.port(port_name)
        if port is None:
            names = [p.name for p in component.interface.ports]
            self.emit(
                codes.ROS2_REFERENCE,
                f"component `{component.name}` has no port `{port_name}` (in ros2.{section})",
                self.key_span(section, key),
                hint=did_you_mean(port_name, names) or one_of(names),
            )
            return None
        return component, port

    def explicit_topics(self) -> set[tuple[str, str]]:
        done: set[tuple[str, str]] = set()
        if not self.spec:
            return done
        for key, entry in self.spec.topics:
            resolved = self.parse_endpoint(key, "topics")
            if resolved is None:
                continue
            component, port = resolved
            spec = entry
            span = self.span("topics", key)
            if port.causality is not Causality.OUTPUT:
                driven = [
                    c
                    for c in self.system.connections
                    if c.dst.component == component.name and c.dst.port == port.name
                ]
                if driven:
                    self.emit(
                        codes.ROS2_UNMAPPED,
                        f"`{key}` is an input driven by `{driven[0].src}`; its topic is that "
                        "output's topic",
                        span,
                        hint=f"set the topic on `{driven[0].src.component}.{driven[0].src.port}`",
                    )
                    continue
            topic_text, text_path = _split_field(spec.topic)
            field_path: str | tuple[str, ...] | None = text_path
            if spec.field is not None:
                field_path = spec.field
            name = expand_topic(topic_text, self.namespace, self.node_names[component.name])
            problem = topic_problem(name)
            if problem is not None:
                self.emit(codes.ROS2_NAME, f"topic `{spec.topic}` of `{key}`: {problem}", span)
                continue
            msgtype = (
                normalize_type(spec.type) if spec.type else self.implied_type(component, port, name)
            )
            publisher = component.name if port.causality is Causality.OUTPUT else None
            if publisher is None or component.external:
                publisher = None
            mapped = self.add_port(name, msgtype, publisher, component, port, field_path, span, key)
            if mapped is not None:
                self.warn_lossy(self.drafts[name].msgtype, mapped, port, span, key)
            if spec.qos is not None:
                self.set_qos(name, spec.qos, ("topics", key))
            done.add((component.name, port.name))
        return done

    def warn_lossy(
        self, msgtype: str, mapped: PortField, port: Port, span: Span, label: str
    ) -> None:
        """W060 when an explicit mapping puts ``port`` onto a field that cannot hold all of its
        values (an ``int64`` on a ``float64`` field rounds above 2^53). In-process the value
        is handed on as it is; on the topic it would change, silently. Defaults never do this
        (each port gets a type of its own element type), so only explicit entries are checked.
        """
        outgoing = port.causality is Causality.OUTPUT
        for path, base in field_bases(msgtype, mapped.paths, self.distro):
            field_dtype = BASE_DTYPE.get(base)
            if field_dtype is None:
                continue
            source, target = (port.dtype, field_dtype) if outgoing else (field_dtype, port.dtype)
            lost = value_loss(source, target)
            if lost is None:
                continue
            where = f"`{path}` of `{msgtype}`"
            message = (
                f"`{label}` ({port.dtype}) is mapped onto {where}, {with_article(base)} field that cannot "
                f"hold every {port.dtype} value: {lost}"
                if outgoing
                else f"`{label}` ({port.dtype}) reads {where}, {with_article(base)} field whose values it "
                f"cannot all hold: {lost}"
            )
            suggestion = default_type(port)
            example = f", e.g. `{suggestion}`" if suggestion not in (None, IMAGE_TYPE) else ""
            hint = (
                f"map it onto {with_article(port.dtype.value)} field{example}, or accept the loss"
            )
            self.emit(codes.ROS2_LOSSY_FIELD, message, span, hint=hint)
            return

    def implied_type(self, component: Component, port: Port, topic: str) -> str | None:
        """The type of a topic entry without ``type``: the port's role default, the type
        already chosen for that topic, or None (the port's default type)."""
        role = role_default(component.kind, port.name, port.causality)
        for connection in self.system.connections:
            if role is None and (connection.src.component, connection.src.port) == (
                component.name,
                port.name,
            ):
                dst = self.system.component(connection.dst.component)
                role = role_default(dst.kind, connection.dst.port, Causality.INPUT)
        if role is not None:
            return role.msgtype
        draft = self.drafts.get(topic)
        return draft.msgtype if draft is not None else None

    def default_topics(self, explicit: set[tuple[str, str]]) -> None:
        for connection in self.system.connections:
            src = connection.src
            if (src.component, src.port) in explicit or (
                src.component,
                src.port,
            ) in self.port_topics:
                continue
            component = self.system.component(src.component)
            dst = self.system.component(connection.dst.component)
            role = role_default(component.kind, src.port, Causality.OUTPUT)
            if role is None:
                role = role_default(dst.kind, connection.dst.port, Causality.INPUT)
            node = self.node_names[component.name]
            span = connection.span or Span(self.system.source)
            publisher = None if component.external else component.name
            if role is not None:
                name = expand_topic(role.topic, self.namespace, node)
                self.add_port(
                    name,
                    role.msgtype,
                    publisher,
                    component,
                    connection.src_port,
                    role.fields,
                    span,
                    str(src),
                )
                continue
            name = expand_topic(f"{node}/{sanitize_token(src.port)}", self.namespace, node)
            self.add_port(
                name, None, publisher, component, connection.src_port, None, span, str(src)
            )

    def add_port(
        self,
        topic: str,
        msgtype: str | None,
        publisher: str | None,
        component: Component,
        port: Port,
        paths: str | tuple[str, ...] | None,
        span: Span,
        label: str,
    ) -> PortField | None:
        """Put ``port`` on ``topic`` (E06x when it cannot be); the field it was given."""
        if msgtype is None:
            msgtype = default_type(port)
            if msgtype is None:
                self.emit(
                    codes.ROS2_UNMAPPED,
                    f"port `{label}` ({port.dtype.value} {port.shape_text()}) has no default "
                    "ROS 2 message type",
                    span,
                    hint="name a message type and field for it under `ros2.topics`",
                )
                return None
        elif msgtype not in self.known_types:
            self.emit(
                codes.ROS2_TYPE,
                f"unknown ROS 2 message type `{msgtype}` for `{label}`",
                span,
                hint=did_you_mean(msgtype, self.known_types)
                or f"types come from the {self.distro.value} message set",
            )
            return None
        mapped = self.fit(msgtype, port, paths, span, label)
        if mapped is None:
            return None
        mapped = _wxyz_quaternion(component, mapped, msgtype, self.distro)
        draft = self.drafts.get(topic)
        if draft is None:
            draft = _Draft(topic, msgtype, publisher, span=span)
            self.drafts[topic] = draft
        elif draft.msgtype != msgtype:
            self.emit(
                codes.ROS2_UNMAPPED,
                f"topic `{topic}` would carry both `{draft.msgtype}` and `{msgtype}`",
                span,
                hint="a topic has one message type; use another topic name",
            )
            return None
        elif draft.publisher != publisher:
            self.emit(
                codes.ROS2_UNMAPPED,
                f"topic `{topic}` would be published by both `{draft.publisher}` and `{publisher}`",
                span,
                hint="ports of different components need different topics",
            )
            return None
        clash = [f for f in draft.fields if set(f.paths) & set(mapped.paths)]
        if clash:
            self.emit(
                codes.ROS2_FIELD,
                f"`{label}` and `{clash[0].port}` both write `{', '.join(mapped.paths)}` of "
                f"`{topic}`",
                span,
            )
            return None
        draft.fields.append(mapped)
        self.port_topics[(component.name, port.name)] = topic
        return mapped

    def fit(
        self,
        msgtype: str,
        port: Port,
        paths: str | tuple[str, ...] | None,
        span: Span,
        label: str,
    ) -> PortField | None:
        """Check that ``port`` fits the field(s) and return the mapping (E061 otherwise)."""
        size = port.size
        shape = tuple(int(d) for d in port.shape) if size is not None else ()
        if size is None:
            self.emit(
                codes.ROS2_UNMAPPED,
                f"port `{label}` has a symbolic shape {port.shape_text()}; ROS 2 mapping needs "
                "fixed sizes",
                span,
            )
            return None
        if isinstance(paths, tuple) and len(paths) > 1:
            if len(paths) != size:
                self.emit(
                    codes.ROS2_FIELD,
                    f"`{label}` has {size} elements but {len(paths)} fields are mapped",
                    span,
                )
                return None
            for element_path in paths:
                element = self.resolve(msgtype, element_path, span, label)
                if element is None or not self.scalar_fits(
                    element, port, element_path, span, label
                ):
                    return None
            return PortField(port.name, paths, shape, port.dtype.value)
        given = paths[0] if isinstance(paths, tuple) else paths
        if given is None or given == WHOLE:
            if msgtype == IMAGE_TYPE and image_geometry(shape) and port.dtype is DType.UINT8:
                return PortField(port.name, (WHOLE,), shape, port.dtype.value)
            given = self.implied_field(msgtype, span, label)
            if given is None:
                return None
        path: str = given
        info = self.resolve(msgtype, path, span, label)
        if info is None:
            return None
        return self.check_fit(info, port, path, shape, size, span, label)

    def implied_field(self, msgtype: str, span: Span, label: str) -> str | None:
        try:
            resolve_field(msgtype, "data", self.distro)
        except FieldError:
            self.emit(
                codes.ROS2_FIELD,
                f"`{label}` maps onto `{msgtype}` without a field and the type has no `data`",
                span,
                hint="write the field after the topic, e.g. `/cmd_vel.linear.x`, or use `field:`",
            )
            return None
        return "data"

    def resolve(self, msgtype: str, path: str, span: Span, label: str) -> FieldInfo | None:
        try:
            return resolve_field(msgtype, path, self.distro)
        except FieldError as exc:
            hint = None
            last = path.rsplit(".", maxsplit=1)[-1]
            if exc.valid:
                hint = did_you_mean(last, exc.valid) or one_of(exc.valid)
            self.emit(codes.ROS2_FIELD, f"`{label}` -> `{msgtype}`: {exc}", span, hint=hint)
            return None

    def scalar_fits(self, info: FieldInfo, port: Port, path: str, span: Span, label: str) -> bool:
        if info.kind is not FieldKind.SCALAR:
            self.emit(
                codes.ROS2_FIELD,
                f"`{path}` is a {info.kind.value} of `{info.base}`; an element of `{label}` "
                "needs a scalar field",
                span,
            )
            return False
        return self.dtype_fits(info, port, path, span, label)

    def dtype_fits(self, info: FieldInfo, port: Port, path: str, span: Span, label: str) -> bool:
        field_dtype = info.dtype
        ok = field_dtype is not None and (
            (field_dtype.is_numeric and port.dtype.is_numeric) or field_dtype is port.dtype
        )
        if not ok:
            self.emit(
                codes.ROS2_FIELD,
                f"field `{path}` holds `{info.base}`, port `{label}` is {port.dtype.value}",
                span,
                hint="map the port onto a field of a matching element type",
            )
        return ok

    def check_fit(
        self,
        info: FieldInfo,
        port: Port,
        path: str,
        shape: tuple[int, ...],
        size: int,
        span: Span,
        label: str,
    ) -> PortField | None:
        mapped = PortField(port.name, (path,), shape, port.dtype.value)
        if info.kind is FieldKind.SCALAR:
            if size != 1:
                self.emit(
                    codes.ROS2_FIELD,
                    f"`{label}` has {size} elements, field `{path}` ({info.base}) holds one",
                    span,
                    hint="map one element (`port[i]` in a connection) or use an array field",
                )
                return None
            return mapped if self.dtype_fits(info, port, path, span, label) else None
        if info.kind is FieldKind.MESSAGE:
            leaves = numeric_leaves(info.base, self.distro)
            if leaves is None or len(leaves) != size:
                count = "non-numeric members" if leaves is None else f"{len(leaves)} members"
                self.emit(
                    codes.ROS2_FIELD,
                    f"field `{path}` is a `{info.base}` with {count}; `{label}` has {size} elements",
                    span,
                )
                return None
            return mapped
        if info.element_is_message:
            self.emit(
                codes.ROS2_FIELD,
                f"field `{path}` is a {info.kind.value} of messages `{info.base}`",
                span,
            )
            return None
        if info.kind is FieldKind.ARRAY and info.length != size:
            self.emit(
                codes.ROS2_FIELD,
                f"field `{path}` is an array of {info.length}, `{label}` has {size} elements",
                span,
            )
            return None
        if info.kind is FieldKind.SEQUENCE and info.length and size > info.length:
            self.emit(
                codes.ROS2_FIELD,
                f"field `{path}` holds at most {info.length} elements, `{label}` has {size}",
                span,
            )
            return None
        return mapped if self.dtype_fits(info, port, path, span, label) else None

    def set_qos(self, topic: str, value: str | QosProfile, path: tuple[str | int, ...]) -> None:
        profile = resolve_qos(value)
        if profile is None:
            self.emit(
                codes.ROS2_QOS,
                f"unknown QoS profile `{value}`",
                self.span(*path),
                hint=did_you_mean(str(value), PROFILES) or one_of(PROFILES),
            )
            return
        draft = self.drafts.get(topic)
        if draft is None:
            return
        if draft.qos is not None and draft.qos != profile:
            self.emit(
                codes.ROS2_QOS,
                f"topic `{topic}` gets two different QoS profiles ({draft.qos.describe()} and "
                f"{profile.describe()})",
                self.span(*path),
                hint="a RELIABLE reader does not match a BEST_EFFORT writer: give a topic one "
                "profile",
            )
            return
        draft.qos = profile

    def apply_qos(self) -> None:
        if not self.spec:
            return
        for key, value in self.spec.qos:
            if key.startswith("/") or "." not in key:
                topic = expand_topic(key, self.namespace)
                if topic not in self.drafts:
                    self.emit(
                        codes.ROS2_REFERENCE,
                        f"ros2.qos names topic `{key}`, which no port is mapped onto",
                        self.key_span("qos", key),
                        hint=did_you_mean(topic, self.drafts) or one_of(self.drafts),
                    )
                    continue
            else:
                resolved = self.parse_endpoint(key, "qos")
                if resolved is None:
                    continue
                found = self.port_topics.get((resolved[0].name, resolved[1].name))
                if found is None:
                    self.emit(
                        codes.ROS2_UNMAPPED,
                        f"ros2.qos names `{key}`, which is not published on a topic",
                        self.key_span("qos", key),
                    )
                    continue
                topic = found
            self.set_qos(topic, value, ("qos", key))

    def finish(self) -> Ros2Plan:
        topics = tuple(
            TopicPlan(
                name=d.name,
                msgtype=d.msgtype,
                qos=d.qos or PROFILES["default"],
                publisher=d.publisher,
                fields=tuple(d.fields),
                frame_id=_frame_id(d),
            )
            for d in self.drafts.values()
        )
        subscriptions = []
        for index, connection in enumerate(self.system.connections):
            topic = self.port_topics.get((connection.src.component, connection.src.port))
            if topic is None or self.system.component(connection.dst.component).external:
                continue
            subscriptions.append(
                Subscription(connection.dst.component, topic, connection.src.port, index)
            )
        for key, topic in self.port_topics.items():
            component = self.system.component(key[0])
            port = component.port(key[1])
            if port.causality is not Causality.OUTPUT and not component.external:
                subscriptions.append(Subscription(component.name, topic, key[1], -1))
        nodes = []
        for component in self.system.components:
            if component.external:
                continue
            publishes = tuple(t.name for t in topics if t.publisher == component.name)
            subscribes = tuple(
                dict.fromkeys(s.topic for s in subscriptions if s.component == component.name)
            )
            nodes.append(
                NodePlan(
                    component.name,
                    self.node_names[component.name],
                    self.namespace,
                    publishes,
                    subscribes,
                )
            )
        external = tuple(c.name for c in self.system.components if c.external)
        return Ros2Plan(
            self.distro, self.namespace, tuple(nodes), topics, tuple(subscriptions), external
        )


QUATERNION = "geometry_msgs/msg/Quaternion"


def _wxyz_quaternion(
    component: Component, mapped: PortField, msgtype: str, distro: RosDistro
) -> PortField:
    """A simulator's quaternion (``w, x, y, z``, MuJoCo's order) mapped onto a whole
    ``Quaternion`` message fills its members by name: the message's order is ``x, y, z, w``."""
    simulator = has_capability(component, SIMULATOR)
    if not simulator or len(mapped.paths) != 1 or mapped.size != 4:
        return mapped
    path = mapped.paths[0]
    if not path or resolve_field(msgtype, path, distro).base != QUATERNION:
        return mapped
    paths = tuple(f"{path}.{axis}" for axis in "wxyz")
    return PortField(mapped.port, paths, mapped.shape, mapped.dtype)


def value_loss(source: DType, target: DType) -> str | None:
    """What converting ``source`` values into ``target`` loses (a phrase), or None.

    The rule of connections (:func:`is_lossy`: float64 -> float32 counts as exact, an integer
    wider than a float's significand is rounded), said of a message field.
    """
    if not is_lossy(source, target):
        return None
    if source.is_integer and target.is_float:
        return f"integers beyond 2^{SIGNIFICAND_BITS[target]} arrive rounded"
    if target is DType.BOOL:
        return "every value other than 0 arrives as 1"
    if source.is_float:
        return "fractions are cut off and values out of its range do not arrive as sent"
    return f"values outside the range of {target} do not arrive as sent"


def field_bases(msgtype: str, paths: tuple[str, ...], distro: RosDistro) -> list[tuple[str, str]]:
    """``(path, ROS base type)`` of every field that one port's values land in: a nested
    message of numbers counts with each of its members; an image (:data:`WHOLE`) is skipped
    (its bytes are the port's own ``uint8``)."""
    found: list[tuple[str, str]] = []
    for path in paths:
        if path == WHOLE:
            continue
        info = resolve_field(msgtype, path, distro)
        if info.kind is FieldKind.MESSAGE:
            for leaf in numeric_leaves(info.base, distro) or ():
                found.append(
                    (f"{path}.{leaf}", resolve_field(msgtype, f"{path}.{leaf}", distro).base)
                )
        elif not info.element_is_message:
            found.append((path, info.base))
    return found


def _frame_id(draft: _Draft) -> str:
    if draft.msgtype == ODOMETRY:
        return "odom"
    return draft.name.strip("/").replace("/", "_") if draft.msgtype == IMAGE_TYPE else ""


def _split_field(text: str) -> tuple[str, str | None]:
    """``/cmd_vel.linear.x`` -> (``/cmd_vel``, ``linear.x``); ROS names never hold a dot."""
    topic, dot, path = text.partition(".")
    return topic, (path if dot else None)


def resolve_qos(value: str | QosProfile | None) -> QosProfile | None:
    """A profile from its name, or the explicit profile; None for an unknown name."""
    if value is None:
        return PROFILES["default"]
    if isinstance(value, QosProfile):
        return value
    return PROFILES.get(value.strip().lower())


def default_type(port: Port) -> str | None:
    """The default message type of a port (see the module table), or None."""
    size = port.size
    if size is None or port.dtype is DType.BINARY:
        return None
    shape = tuple(int(d) for d in port.shape)
    if port.dtype is DType.UINT8 and image_geometry(shape) is not None:
        return IMAGE_TYPE
    if port.dtype is DType.STRING:
        return STRING if port.is_scalar else None
    if port.dtype.is_integer:
        return integer_type(port.dtype, scalar=port.is_scalar)
    return FLOAT64 if port.is_scalar else FLOAT64_ARRAY


def integer_type(dtype: DType, *, scalar: bool) -> str:
    """``std_msgs/msg/Int64`` for an ``int64`` scalar, ``.../UInt8MultiArray`` for a
    ``uint8`` array: std_msgs has one of each for every integer width of the IR."""
    unsigned = dtype.value.startswith("u")
    bits = dtype.value.removeprefix("u").removeprefix("int")
    name = f"{'U' if unsigned else ''}Int{bits}"
    return f"std_msgs/msg/{name}" if scalar else f"std_msgs/msg/{name}MultiArray"


def build_plan(
    system: CompiledSystem,
    distro: RosDistro = DEFAULT_DISTRO,
    sources: SourceMap | None = None,
) -> tuple[Ros2Plan | None, list[Diagnostic]]:
    """The ROS 2 plan of ``system`` and every problem found (the plan is None on errors)."""
    builder = _Builder(system, distro, sources)
    plan = builder.run()
    return plan, sorted(builder.diagnostics, key=Diagnostic.sort_key)


def check_ros2(
    system: CompiledSystem,
    sources: SourceMap | None = None,
    distro: RosDistro = DEFAULT_DISTRO,
) -> list[Diagnostic]:
    """Diagnostics E060..E065 and W060 for mapping ``system`` onto ROS 2 (empty when it maps).

    ``sources`` (the front end's source map) gives ``path:line:col`` spans for the ``ros2:``
    section; without it, spans point at the system file (and connections at their line).
    """
    return build_plan(system, distro, sources)[1]


def describe(plan: Ros2Plan) -> Sequence[str]:
    """One line per topic: ``/cmd_vel  geometry_msgs/msg/Twist  tracker -> world``."""
    lines = []
    for topic in plan.topics:
        readers = sorted({s.component for s in plan.subscriptions if s.topic == topic.name})
        lines.append(
            f"{topic.name}  {topic.msgtype}  {topic.publisher or '(external)'} -> "
            f"{', '.join(readers) or '(none)'}"
        )
    return lines
