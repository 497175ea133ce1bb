"""The ``ros2:`` section of a system file, resolved into :class:`Ros2Settings`.

The only place where the ROS 2 part of the compiled system meets the front end's model:
explicit QoS profiles become :class:`QosProfile` values, topic strings become
:class:`TopicSetting` entries, and nothing after this needs the raw spec.
"""

from __future__ import annotations

from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.qos import Durability, QosProfile, Reliability
from fmionnx.compile.ros2.types import Ros2Settings, TopicSetting
from fmionnx.spec.model import QosSpec, Ros2Spec, TopicSpec


def _qos(value: str | QosSpec) -> str | QosProfile:
    if isinstance(value, QosSpec):
        return QosProfile(Reliability(value.reliability), Durability(value.durability), value.depth)
    return value


def _topic(entry: str | TopicSpec) -> TopicSetting:
    if isinstance(entry, str):
        return TopicSetting(topic=entry)
    field = tuple(entry.field) if isinstance(entry.field, list) else entry.field
    qos = _qos(entry.qos) if entry.qos is not None else None
    return TopicSetting(topic=entry.topic, type=entry.type, field=field, qos=qos)


def ros2_settings(spec: Ros2Spec) -> Ros2Settings:
    """The resolved settings of a ``ros2:`` section (entries keep the file's order)."""
    return Ros2Settings(
        namespace=spec.namespace,
        distro=RosDistro(spec.distro),
        nodes=tuple(spec.nodes.items()),
        topics=tuple((key, _topic(entry)) for key, entry in spec.topics.items()),
        qos=tuple((key, _qos(value)) for key, value in spec.qos.items()),
    )
