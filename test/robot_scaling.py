"""The network scaling of a robot's joint limits, as the tests set up their networks."""
from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES
from scara_ident_ros.nn.presets import limit_scaling


class Robot(Protocol):
    """A robot model with per-joint limit arrays (ScaraParams, PinocchioRobot)."""

    def array(self, name: str) -> np.ndarray: ...


def robot_scaling(robot: Robot, joints: Sequence[int] | slice = slice(None)
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``limit_scaling`` of the robot's limits of ``joints`` (all by default): input ranges
    x_min, x_max of shape (3n,) in the order [q, q', q''], output ranges y_min, y_max (n,)."""
    return limit_scaling(*(robot.array(key)[joints] for key in LIMIT_NAMES))
