"""Limits from a URDF, the margins, and the check of sampled motion."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.joint_limits import JointLimits, LimitsError
from scara_ident_ros.excitation import load_motion_limits

URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'


def test_the_scara_urdf_gives_the_yaml_limits(limits: JointLimits) -> None:
    assert limits.names == ('joint1', 'joint2', 'joint3', 'joint4')
    np.testing.assert_array_equal(limits.position_max, [2.3, 2.5, 0.2, 6.28])
    np.testing.assert_array_equal(limits.velocity_max, [7.0, 12.0, 1.1, 26.0])
    np.testing.assert_array_equal(limits.acceleration_max, [30.0, 50.0, 10.0, 150.0])


def test_margins_shrink_the_range_and_scale_the_limits(limits: JointLimits,
                                                       margined: JointLimits) -> None:
    np.testing.assert_allclose(margined.position_min, [-1.84, -2.0, 0.02, -5.024])
    np.testing.assert_allclose(margined.velocity_max, 0.5 * limits.velocity_max)
    np.testing.assert_allclose(margined.acceleration_max, 0.5 * limits.acceleration_max)
    with pytest.raises(LimitsError, match='position_margin'):
        limits.with_margins(0.5, 0.5, 0.5)
    with pytest.raises(LimitsError, match='velocity_scale'):
        limits.with_margins(0.1, 0.0, 0.5)


def test_violations_name_the_joint_and_the_kind(margined: JointLimits) -> None:
    q = np.tile(margined.centre, (3, 1))
    zero = np.zeros_like(q)
    assert margined.violations(q, zero, zero) == []
    fast = zero.copy()
    fast[1, 2] = 1.01 * margined.velocity_max[2]
    assert margined.violations(q, fast, zero) == [
        f'joint3: |velocity| {fast[1, 2]:g} above {margined.velocity_max[2]:g}']
    low = q.copy()
    low[0, 0] = -2.0
    assert 'joint1: position' in margined.violations(low, zero, zero)[0]
    start = margined.centre.copy()
    start[0] = -2.1
    assert margined.violations(low, zero, zero, position_hull=start) == []


@pytest.mark.parametrize('urdf, names, match', [
    ('', [], 'no URDF'),
    ('<robot name="r"><joint name="a" type="continuous"><parent link="x"/><child link="y"/>'
     '</joint></robot>', ['a'], 'continuous'),
    ('<robot name="r"><joint name="a" type="revolute"/></robot>', [], 'no joint with'),
    ('<robot name="r"><joint name="a" type="revolute"/></robot>', ['a'], 'no <limit>'),
    ('<robot name="r"><joint name="a" type="fixed"/></robot>', [], 'no joint with'),
])
def test_a_urdf_without_limits_is_refused_in_one_line(urdf: str, names: list[str],
                                                      match: str) -> None:
    with pytest.raises(LimitsError, match=match) as error:
        load_motion_limits(robot_description=urdf, joint_names=names)
    assert '\n' not in str(error.value)


def test_acceleration_limits_by_parameter(tmp_path: Path) -> None:
    limits = load_motion_limits(urdf_file=str(URDF), joint_names=['joint2', 'joint1'],
                                acceleration_max=[5.0, 4.0])
    assert limits.names == ('joint2', 'joint1')
    np.testing.assert_array_equal(limits.acceleration_max, [5.0, 4.0])
    np.testing.assert_array_equal(limits.velocity_max, [12.0, 7.0])
    with pytest.raises(LimitsError, match='acceleration'):
        load_motion_limits(urdf_file=str(URDF), joint_names=['joint1', 'joint2'],
                           acceleration_max=[5.0])
