"""Environment defaults that keep DDS traffic on this machine."""
from __future__ import annotations

import os

__all__ = ['ensure_local_dds']


def ensure_local_dds() -> None:
    """Set ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` unless the user chose a range.

    Must run before ``rclpy.init``: without it Fast DDS multicasts discovery
    traffic off the machine.
    """
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
