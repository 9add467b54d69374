"""Self-collision of a URDF's links (Pinocchio's collision model), and the optimised motion
shrunk until its links stay apart."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.excitation.optimized_excitation import (COLLISION_SHRINK,
                                                             _collision_free_scale)
from scara_ident_ros.excitation.self_collision import self_collision
from scara_ident_ros.sim.trajectory import FourierTrajectory

sys.path.insert(0, str(Path(__file__).parents[1]))  # --import-mode=importlib
from physical_robots import SCARA_URDF, example_urdf  # noqa: E402

UR5 = ('shoulder_pan_joint', 'shoulder_lift_joint', 'elbow_joint', 'wrist_1_joint',
       'wrist_2_joint', 'wrist_3_joint')


def test_the_ur5s_forearm_meets_its_upper_arm_only_when_folded() -> None:
    check = self_collision(example_urdf('ur_description/urdf/ur5_robot.urdf'), UR5,
                           np.zeros(6))
    assert check is not None and check.n_pairs > 0
    elbow = np.array([0.0, 2.5, 2.9, -3.1])
    q = np.zeros((4, 6))
    q[:, 1], q[:, 2] = -1.57, elbow
    np.testing.assert_array_equal(check.colliding(q), [False, False, True, True])


def test_a_urdf_without_collision_geometry_has_nothing_to_check() -> None:
    assert self_collision(SCARA_URDF, ('joint1', 'joint2', 'joint3', 'joint4'),
                          np.zeros(4)) is None


class _Ball:
    """Links that meet wherever a joint is more than ``reach`` from the middle."""

    def __init__(self, reach: float) -> None:
        self.reach = reach

    def colliding(self, q: np.ndarray) -> np.ndarray:
        return np.any(np.abs(q) > self.reach, axis=1)


def test_the_motion_is_shrunk_until_its_links_stay_apart() -> None:
    trajectory = FourierTrajectory(np.zeros(2), np.array([[1.0, 0.5], [0.3, 0.2]]),
                                   np.array([[0.2, 0.1], [0.4, 0.0]]), 0.25)
    peak = float(np.abs(trajectory.evaluate(trajectory.grid(20))[0]).max())
    assert _collision_free_scale(trajectory, _Ball(2.0 * peak)) == 1.0  # type: ignore[arg-type]
    scale = _collision_free_scale(trajectory, _Ball(0.6 * peak))  # type: ignore[arg-type]
    assert scale == pytest.approx(COLLISION_SHRINK ** 3)  # 0.512 < 0.6 < 0.64
