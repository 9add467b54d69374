"""Joint limits chosen as the identifier's parameters say (or from a URDF, as the excitation
takes them), selected, turned into bounds, and margins and sampled motion checked against."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scara_ident_ros.dynamics import ParamError, ScaraParams
from scara_ident_ros.dynamics.urdf_limits import UrdfError
from scara_ident_ros.dynamics.joint_limits import (LIMIT_NAMES, JointLimits, LimitsError,
                                                   load_joint_limits, load_motion_limits)
from scara_ident_ros.identification.sample_check import joint_bounds
from scara_ident_ros.nn.presets import limit_scaling

ROOT = Path(__file__).resolve().parents[2]
URDF = ROOT / 'urdf' / 'scara.urdf'
YAML = ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')
TWO = {'position_min': [-1.0, 0.0], 'position_max': [1.0, 0.5], 'velocity_max': [2.0, 1.0],
       'acceleration_max': [10.0, 5.0], 'effort_max': [20.0, 100.0]}
MOTION = load_motion_limits(urdf_file=str(URDF))  # the SCARA's, as the excitation takes them
MARGINED = MOTION.with_margins(0.1, 0.5, 0.5)  # with the excitation node's default margins


def test_the_default_is_the_robot_yaml() -> None:
    limits = load_joint_limits()
    assert limits.names == YAML.joint_names and limits.source == 'robot_config'
    for key in LIMIT_NAMES:
        np.testing.assert_array_equal(getattr(limits, key), YAML.array(key), err_msg=key)


def test_a_urdf_gives_the_same_limits_with_the_yaml_accelerations() -> None:
    from_urdf = load_joint_limits(urdf_file=str(URDF))
    assert from_urdf.names == YAML.joint_names
    assert from_urdf.source == f'{URDF} (acceleration_max from {ROOT / "config" / "scara.yaml"})'
    for key in LIMIT_NAMES:
        np.testing.assert_array_equal(getattr(from_urdf, key), YAML.array(key), err_msg=key)
    text = load_joint_limits(robot_description=URDF.read_text(), joint_names=['joint2'],
                             explicit={'acceleration_max': [7.0]})
    assert text.names == ('joint2',)
    assert text.source == 'robot_description (acceleration_max from parameters)'
    np.testing.assert_array_equal(text.acceleration_max, [7.0])


def test_explicit_limits_name_their_joints() -> None:
    limits = load_joint_limits(joint_names=['a', 'b'], explicit=TWO)
    assert limits.names == ('a', 'b')
    np.testing.assert_array_equal(limits.effort_max, [20.0, 100.0])


@pytest.mark.parametrize(('options', 'error', 'message'), [
    ({'explicit': {**TWO, 'effort_max': []}, 'joint_names': ['a', 'b']}, LimitsError,
     'must all be given'),
    ({'explicit': TWO, 'joint_names': ['a']}, LimitsError, 'need joint_names'),
    ({'urdf_file': str(URDF), 'robot_description': 'x'}, LimitsError, 'not both'),
    ({'urdf_file': str(URDF), 'explicit': {'effort_max': [1.0]}}, LimitsError,
     'effort_max: the URDF gives these limits'),
    ({'urdf_file': str(URDF), 'explicit': {'acceleration_max': [1.0]}}, LimitsError,
     'acceleration_max needs joint_names'),
    ({'urdf_file': str(URDF), 'joint_names': ['shoulder']}, UrdfError,
     'no joint limits for shoulder'),
    ({'robot_config': '/nowhere/robot.yaml'}, ParamError, 'nowhere'),
    ({'robot_config': str(URDF)}, ParamError, 'scara.urdf'),
])
def test_bad_options_say_what_is_wrong(options: dict[str, Any], error: type[Exception],
                                       message: str) -> None:
    with pytest.raises(error, match=message):
        load_joint_limits(**options)


@pytest.mark.parametrize(('names', 'change', 'message'), [
    (['a', 'a'], {}, 'parameters: joint names must be distinct'),
    (['a', 'b'], {'velocity_max': [2.0, float('nan')]}, 'velocity_max must be 2 finite'),
    (['a', 'b'], {'position_max': [1.0, 0.0]}, 'position_min must be below position_max'),
    (['a', 'b'], {'effort_max': [20.0, 0.0]}, 'effort limits must be > 0'),
])
def test_unusable_limits_are_refused_in_one_line(names: list[str], change: dict[str, Any],
                                                 message: str) -> None:
    with pytest.raises(LimitsError, match=message) as error:
        load_joint_limits(joint_names=names, explicit={**TWO, **change})
    assert '\n' not in str(error.value)


def test_select_orders_and_says_what_is_missing() -> None:
    limits = JointLimits.of(['a', 'b'], TWO, source='test')
    assert limits.missing(['b', 'c']) == ['c']
    chosen = limits.select(['b', 'a'])
    assert chosen.names == ('b', 'a') and chosen.source == 'test'
    np.testing.assert_array_equal(chosen.position_max, [0.5, 1.0])
    with pytest.raises(LimitsError, match=r"for \['c'\] .*\['a', 'b'\], from test"):
        limits.select(['a', 'c'])


def test_scaling_and_bounds() -> None:
    limits = JointLimits.of(['a', 'b'], TWO)
    for ours, theirs in zip(limits.scaling(), limit_scaling(*TWO.values()), strict=True):
        np.testing.assert_array_equal(ours, theirs)
    assert joint_bounds(limits, -1.0) is None
    bounds = joint_bounds(limits, 0.5)
    assert bounds is not None
    np.testing.assert_allclose(bounds.lo[0], [-2.0, -0.25])  # range 2 and 0.5, half beyond
    np.testing.assert_allclose(bounds.hi[2], [30.0, 150.0])  # effort limits x 1.5


def test_the_scara_urdf_gives_the_yaml_limits() -> None:
    assert MOTION.names == ('joint1', 'joint2', 'joint3', 'joint4')
    np.testing.assert_array_equal(MOTION.position_max, [2.3, 2.5, 0.2, 6.28])
    np.testing.assert_array_equal(MOTION.velocity_max, [7.0, 12.0, 1.1, 26.0])
    np.testing.assert_array_equal(MOTION.acceleration_max, [30.0, 50.0, 10.0, 150.0])


def test_margins_shrink_the_range_and_scale_the_limits() -> None:
    np.testing.assert_allclose(MARGINED.position_min, [-1.84, -2.0, 0.02, -5.024])
    np.testing.assert_allclose(MARGINED.velocity_max, 0.5 * MOTION.velocity_max)
    np.testing.assert_allclose(MARGINED.acceleration_max, 0.5 * MOTION.acceleration_max)
    with pytest.raises(LimitsError, match='position_margin'):
        MOTION.with_margins(0.5, 0.5, 0.5)
    with pytest.raises(LimitsError, match='velocity_scale'):
        MOTION.with_margins(0.1, 0.0, 0.5)


def test_violations_name_the_joint_and_the_kind() -> None:
    q = np.tile(MARGINED.centre, (3, 1))
    zero = np.zeros_like(q)
    assert MARGINED.violations(q, zero, zero) == []
    fast = zero.copy()
    fast[1, 2] = 1.01 * MARGINED.velocity_max[2]
    assert MARGINED.violations(q, fast, zero) == [
        f'joint3: |velocity| {fast[1, 2]:g} above {MARGINED.velocity_max[2]:g}']
    low = q.copy()
    low[0, 0] = -2.0
    assert 'joint1: position' in MARGINED.violations(low, zero, zero)[0]
    start = MARGINED.centre.copy()
    start[0] = -2.1
    assert MARGINED.violations(low, zero, zero, position_hull=start) == []


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


def test_acceleration_limits_by_parameter() -> None:
    limits = load_motion_limits(urdf_file=str(URDF), joint_names=['joint2', 'joint1'],
                                acceleration_max=[5.0, 4.0])
    assert limits.names == ('joint2', 'joint1')
    np.testing.assert_array_equal(limits.acceleration_max, [5.0, 4.0])
    np.testing.assert_array_equal(limits.velocity_max, [12.0, 7.0])
    with pytest.raises(LimitsError, match='acceleration'):
        load_motion_limits(urdf_file=str(URDF), joint_names=['joint1', 'joint2'],
                           acceleration_max=[5.0])


def test_partial_limits_leave_joints_without_acceleration_to_the_stream() -> None:
    from scara_ident_ros.sim.example_robots import example_robot

    panda = str(example_robot('panda').urdf)
    arm = [f'panda_joint{i}' for i in range(1, 8)]
    # the default robot YAML is the SCARA's: its accelerations are for its own URDF only
    limits = load_joint_limits(urdf_file=panda, joint_names=arm, partial=True)
    assert limits.names == ()
    with pytest.raises(UrdfError, match='no acceleration limit'):
        load_joint_limits(urdf_file=panda, joint_names=arm)
    with pytest.raises(UrdfError, match=r'no joint limits for shoulder \(not in the URDF\)'):
        load_joint_limits(urdf_file=panda, joint_names=[*arm, 'shoulder'], partial=True)
    given = load_joint_limits(urdf_file=panda, joint_names=arm[:2], partial=True,
                              explicit={'acceleration_max': [5.0, 6.0]})
    assert given.names == tuple(arm[:2])
    assert given.source == f'{panda} (acceleration_max from parameters)'
