"""ROS 2 names: validation (as ``rmw_validate_*`` does) and the mapping onto DDS topic names.

A ROS topic ``/cmd_vel`` is the DDS topic ``rt/cmd_vel``. Relative names are resolved against
the node's namespace, ``~/x`` against the node itself (rcl's name expansion, without
substitutions).
"""

from __future__ import annotations

import re

#: Prefix of DDS topics that carry ROS 2 topics (``rq``/``rr`` are services).
TOPIC_PREFIX = "rt"

_TOKEN = r"[A-Za-z_][A-Za-z0-9_]*"
_NODE_RE = re.compile(rf"^{_TOKEN}$")
_NAMESPACE_RE = re.compile(rf"^(/|(/{_TOKEN})+)$")
_TOPIC_TOKEN = r"[A-Za-z0-9_]+"
_FULL_TOPIC_RE = re.compile(rf"^(/{_TOPIC_TOKEN})+$")
_MAX_NAME = 255


def node_name_problem(name: str) -> str | None:
    """Why ``name`` is not a valid node name, or None."""
    if not name:
        return "a node name must not be empty"
    if len(name) > _MAX_NAME:
        return f"a node name has at most {_MAX_NAME} characters"
    if name[0].isdigit():
        return "a node name must not start with a digit"
    if not _NODE_RE.match(name):
        return "a node name contains only letters, digits and `_`"
    return None


def namespace_problem(namespace: str) -> str | None:
    """Why ``namespace`` is not a valid absolute namespace (``""`` means ``/``), or None."""
    if namespace in ("", "/"):
        return None
    if not namespace.startswith("/"):
        return "a namespace must be absolute (start with `/`)"
    if namespace.endswith("/"):
        return "a namespace must not end with `/`"
    if not _NAMESPACE_RE.match(namespace):
        return (
            "each part of a namespace starts with a letter or `_` and has only letters, digits, `_`"
        )
    return None


def expand_topic(name: str, namespace: str = "", node: str = "") -> str:
    """The fully qualified topic name (``cmd_vel`` in ``/robot`` -> ``/robot/cmd_vel``)."""
    base = namespace.rstrip("/")
    if name.startswith("/"):
        return name
    if name.startswith("~"):
        rest = name[1:].lstrip("/")
        return f"{base}/{node}" + (f"/{rest}" if rest else "")
    return f"{base}/{name}"


def topic_problem(full_name: str) -> str | None:
    """Why a fully qualified topic name is invalid (``rmw_validate_full_topic_name``), or None."""
    if not full_name.startswith("/"):
        return "a topic name must be absolute after expansion"
    if full_name.endswith("/"):
        return "a topic name must not end with `/`"
    if "//" in full_name:
        return "a topic name must not contain `//`"
    if not _FULL_TOPIC_RE.match(full_name):
        return "a topic name contains only letters, digits, `_` and `/`"
    if any(token[0].isdigit() for token in full_name.split("/") if token):
        return "no part of a topic name may start with a digit"
    if len(TOPIC_PREFIX) + len(full_name) > _MAX_NAME:
        return f"a topic name has at most {_MAX_NAME - len(TOPIC_PREFIX)} characters"
    return None


def dds_topic(full_name: str) -> str:
    """``/cmd_vel`` -> ``rt/cmd_vel``."""
    return TOPIC_PREFIX + full_name


def ros_topic(dds_name: str) -> str | None:
    """``rt/cmd_vel`` -> ``/cmd_vel``; None for DDS topics that are not ROS topics."""
    if dds_name.startswith(TOPIC_PREFIX + "/"):
        return dds_name[len(TOPIC_PREFIX) :]
    return None


def sanitize_token(text: str) -> str:
    """Turn a port or component name into a valid name token (``base_quat[0]`` -> ``base_quat_0``).

    Used for default node and topic names; invalid characters become ``_``.
    """
    token = re.sub(r"[^A-Za-z0-9_]+", "_", text).strip("_") or "_"
    return f"_{token}" if token[0].isdigit() else token
