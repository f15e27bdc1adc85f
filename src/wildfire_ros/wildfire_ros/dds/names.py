"""ROS 2 name rules: validation, expansion of relative/private names, remapping."""

from __future__ import annotations

import re

from wildfire_msgs_py.errors import TopicNameError

_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_NODE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def validate_namespace(namespace: str) -> str:
    """A normalized absolute namespace (``""`` and ``uav0`` become ``/`` and ``/uav0``)."""
    if not namespace:
        return "/"
    if not namespace.startswith("/"):
        namespace = "/" + namespace
    if namespace != "/":
        namespace = namespace.rstrip("/")
        for token in namespace[1:].split("/"):
            if not _TOKEN.match(token):
                raise TopicNameError(
                    f"namespace {namespace!r}: expected /-separated names of letters, digits "
                    "and underscores, not starting with a digit"
                )
    return namespace


def validate_node_name(name: str) -> str:
    """A node name: letters, digits, underscores, not starting with a digit."""
    if not _NODE_NAME.match(name):
        raise TopicNameError(
            f"node name {name!r}: expected letters, digits and underscores, "
            "not starting with a digit"
        )
    return name


def expand_topic_name(name: str, node_name: str, namespace: str) -> str:
    """Absolute topic name as rcl expands it: ``odom`` in ``/uav0`` -> ``/uav0/odom``."""
    if not name:
        raise TopicNameError("topic name is empty: expected e.g. /wildfire/fire_map")
    if name.startswith("~"):
        base = namespace.rstrip("/") + "/" + node_name
        expanded = base + name[1:]
    elif name.startswith("/"):
        expanded = name
    else:
        expanded = namespace.rstrip("/") + "/" + name
    expanded = expanded.replace("{node}", node_name).replace("{ns}", namespace)
    tokens = expanded[1:].split("/")
    if expanded.endswith("/") or not all(_TOKEN.match(token) for token in tokens):
        raise TopicNameError(
            f"topic name {name!r}: expected /-separated names of letters, digits and "
            "underscores, not starting with a digit (e.g. /uav0/odom)"
        )
    return expanded


__all__ = ["expand_topic_name", "validate_namespace", "validate_node_name"]
