"""The Python class of a ROS message type name, for creating publishers and subscriptions.

rclpy needs the generated class (its type support) even for raw (serialized) traffic.
``rosidl_runtime_py`` is not among the PyPI wheels, so the class is imported from the
package's ``msg`` module: ``'sensor_msgs/msg/JointState'`` ->
``sensor_msgs.msg.JointState``. Importing a message package does not import rclpy.
"""
from __future__ import annotations

import importlib
import re
from typing import Any

__all__ = ['message_class']

_NAME = re.compile(r'^(?P<package>\w+)/(?P<kind>msg)/(?P<name>\w+)$')


def message_class(msgtype: str) -> Any | None:
    """Return the class for ``msgtype`` (e.g. ``'std_msgs/msg/Float64'``), None if unknown."""
    match = _NAME.match(msgtype)
    if match is None:
        return None
    try:
        module = importlib.import_module(f"{match['package']}.{match['kind']}")
    except ImportError:
        return None
    cls = getattr(module, match['name'], None)
    return cls if isinstance(cls, type) else None
