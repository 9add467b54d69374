"""Test-wide set-up: DDS stays on this machine and each run gets its own domain."""
from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import IO

# Before anything imports rclpy: keep Fast DDS discovery on loopback, and keep
# this test run (and the processes it starts) in a domain of its own so parallel
# runs on the same machine do not hear each other.
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ros_domains import claim_domain  # noqa: E402  (test/ is no package)

_held: IO[str] | None = None  # the lock of this run's domain, held until the process ends
if 'ROS_DOMAIN_ID' not in os.environ:
    _domain, _held = claim_domain()
    os.environ['ROS_DOMAIN_ID'] = str(_domain)
