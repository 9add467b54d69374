"""The DDS environment of a benchmark's ROS processes: this machine only, a domain of its own.

Every benchmark that starts nodes takes its environment from :func:`ros_env`:
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` unless the user set a range, and the user's
``ROS_DOMAIN_ID`` if set, else a domain claimed by the test suite's lock
(``test/ros_domains.py``), held until the benchmark ends, so that no test run and no other
benchmark on this machine can share it (a pid modulo could: two graphs on one domain mix
their samples).
"""
from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import IO

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
from ros_domains import claim_domain  # noqa: E402  (test/ is no package)

__all__ = ['ros_env']

_claimed: list[tuple[int, IO[str]]] = []  # this process's domain and its open lock


def ros_env(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: ``os.environ``) with the discovery range and the domain set."""
    env = dict(os.environ if base is None else base)
    env.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    if 'ROS_DOMAIN_ID' not in env:
        if not _claimed:
            _claimed.append(claim_domain())
        env['ROS_DOMAIN_ID'] = str(_claimed[0][0])
    return env
