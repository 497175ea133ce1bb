"""The ROS 2 plan and settings: what the compiled system carries about ROS 2.

:mod:`fmionnx.compile.ros2.plan` derives a :class:`Ros2Plan` from the compiled components and
the resolved ``ros2:`` section (:class:`Ros2Settings`); the ROS 2 backend starts exactly what
the plan says. Both are plain frozen data, so they serialise with the rest of the system.
"""

from __future__ import annotations

from dataclasses import dataclass

from fmionnx.compile.ros2.distro import DEFAULT_DISTRO, RosDistro
from fmionnx.compile.ros2.fields import PortField
from fmionnx.compile.ros2.qos import QosProfile


@dataclass(frozen=True, slots=True)
class TopicSetting:
    """A ``ros2.topics`` entry: topic (may carry a field: ``/cmd_vel.linear.x``), type, field
    path(s) and QoS (a profile name, checked when planning, or an explicit profile)."""

    topic: str
    type: str | None = None
    field: str | tuple[str, ...] | None = None
    qos: str | QosProfile | None = None


@dataclass(frozen=True, slots=True)
class Ros2Settings:
    """The ``ros2:`` section of a system, resolved: only what differs from the defaults."""

    namespace: str = ""
    distro: RosDistro = DEFAULT_DISTRO
    nodes: tuple[tuple[str, str], ...] = ()
    topics: tuple[tuple[str, TopicSetting], ...] = ()
    qos: tuple[tuple[str, str | QosProfile], ...] = ()


@dataclass(frozen=True, slots=True)
class TopicPlan:
    """One ROS topic: its publisher (None: expected from outside) and what fills it."""

    name: str
    msgtype: str
    qos: QosProfile
    publisher: str | None
    fields: tuple[PortField, ...]
    frame_id: str = ""

    def field_of(self, port: str) -> PortField:
        """The field mapping of one of the publisher's ports."""
        for item in self.fields:
            if item.port == port:
                return item
        raise KeyError(port)


@dataclass(frozen=True, slots=True)
class Subscription:
    """A node reads ``topic`` and takes the value of the publisher's port ``src_port``."""

    component: str
    topic: str
    src_port: str
    connection_index: int


@dataclass(frozen=True, slots=True)
class NodePlan:
    """One node: its component, name, topics written and read."""

    component: str
    name: str
    namespace: str
    publishes: tuple[str, ...]
    subscribes: tuple[str, ...]

    @property
    def fqn(self) -> str:
        """``/ns/name``."""
        return self.namespace.rstrip("/") + "/" + self.name


@dataclass(frozen=True, slots=True)
class Ros2Plan:
    """Everything the ROS 2 backend starts, derived from the compiled system."""

    distro: RosDistro
    namespace: str
    nodes: tuple[NodePlan, ...]
    topics: tuple[TopicPlan, ...]
    subscriptions: tuple[Subscription, ...]
    external: tuple[str, ...] = ()

    def topic(self, name: str) -> TopicPlan:
        """The topic called ``name`` (fully qualified)."""
        for topic in self.topics:
            if topic.name == name:
                return topic
        raise KeyError(name)

    def topic_of(self, component: str, port: str) -> TopicPlan | None:
        """The topic a component's port is published on, or None."""
        for topic in self.topics:
            if topic.publisher == component and any(f.port == port for f in topic.fields):
                return topic
        return None

    def node(self, component: str) -> NodePlan:
        """The node of ``component``."""
        for node in self.nodes:
            if node.component == component:
                return node
        raise KeyError(component)
