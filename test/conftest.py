"""Test-wide set-up: DDS stays on this machine and each run gets its own domain."""
from __future__ import annotations

import os

# Before anything imports rclpy: keep Fast DDS discovery on loopback, and keep
# this test run (and the processes it starts) in a domain of its own so parallel
# runs on the same machine do not hear each other.
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('ROS_DOMAIN_ID', str(100 + os.getpid() % 100))
