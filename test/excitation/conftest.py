"""The SCARA's limits from its URDF (acceleration limits from config/scara.yaml), with the
excitation node's default margins."""
from __future__ import annotations

from pathlib import Path

import pytest

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation import load_motion_limits

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / 'urdf' / 'scara.urdf'


@pytest.fixture(scope='session')
def limits() -> JointLimits:
    return load_motion_limits(urdf_file=str(URDF), robot_config=str(ROOT / 'config' /
                                                                    'scara.yaml'))


@pytest.fixture(scope='session')
def margined(limits: JointLimits) -> JointLimits:
    return limits.with_margins(0.1, 0.5, 0.5)
