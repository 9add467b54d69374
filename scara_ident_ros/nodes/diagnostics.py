"""Publish a node's :class:`~scara_ident_ros.nodes.health.Health` on ``/diagnostics``.

One ``diagnostic_msgs/DiagnosticArray`` per :data:`PERIOD` with one ``DiagnosticStatus``
named ``'<node fqn>: <what>'`` (e.g. ``'/ffmw/identifier: identification'``), as
``diagnostic_updater`` names them, so ``rqt_robot_monitor`` and Foxglove's diagnostics
panel list each node's level, message and figures.
"""
from __future__ import annotations

import time
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from scara_ident_ros.nodes.health import Health
from scara_ident_ros.topics import DIAGNOSTICS

__all__ = ['PERIOD', 'Diagnostics', 'to_status']

PERIOD = 1.0  # s between two reports


def to_status(health: Health, name: str, hardware_id: str = '') -> DiagnosticStatus:
    """The ``DiagnosticStatus`` of ``health``."""
    return DiagnosticStatus(
        level=bytes([int(health.level)]), name=name, message=health.message,
        hardware_id=hardware_id,
        values=[KeyValue(key=key, value=value) for key, value in health.values.items()])


class Diagnostics:
    """Report ``check(period_s)`` of a node on ``/diagnostics`` every :data:`PERIOD`.

    Parameters
    ----------
    node : Node
        The node that publishes (its timer calls ``check``).
    what : str
        What the status is about, appended to the node's name.
    check : callable
        Returns the node's health over the ``period_s`` seconds since the previous call.
    hardware_id : str
        The status's ``hardware_id``: '' for software, the robot's name for a (simulated)
        robot.
    """

    def __init__(self, node: Node, what: str, check: Callable[[float], Health], *,
                 hardware_id: str = '') -> None:
        self.node = node
        self.name = f'{node.get_fully_qualified_name()}: {what}'
        self.check = check
        self.hardware_id = hardware_id
        self.publisher = node.create_publisher(DiagnosticArray, DIAGNOSTICS, 10)
        self._last = time.monotonic()
        self.timer = node.create_timer(PERIOD, self.publish)

    def publish(self) -> None:
        """Publish the node's status now."""
        now = time.monotonic()
        period_s, self._last = max(now - self._last, 1e-3), now
        msg = DiagnosticArray(status=[to_status(self.check(period_s), self.name,
                                                self.hardware_id)])
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.publisher.publish(msg)
