"""Tests of the by-name mapping of message joints to the configured order."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification import JointMap, SkipReason

NAMES = ('joint1', 'joint2', 'joint3', 'joint4')


def test_in_order_is_the_identity() -> None:
    perm = JointMap(NAMES).permutation(list(NAMES))
    assert isinstance(perm, np.ndarray)
    assert perm.tolist() == [0, 1, 2, 3]


def test_reordered_names_map_by_name() -> None:
    joint_map = JointMap(NAMES)
    message = ['joint3', 'joint1', 'joint4', 'joint2']
    values = np.array([3.0, 1.0, 4.0, 2.0])
    perm = joint_map.permutation(message)
    assert isinstance(perm, np.ndarray)
    assert values[perm].tolist() == [1.0, 2.0, 3.0, 4.0]
    # The cache of the last order must not leak into the next, different order.
    perm = joint_map.permutation(NAMES)
    assert isinstance(perm, np.ndarray)
    assert perm.tolist() == [0, 1, 2, 3]
    assert values[joint_map.permutation(tuple(message))].tolist() == [1.0, 2.0, 3.0, 4.0]


@pytest.mark.parametrize('names, reason', [
    (['joint1', 'joint2', 'joint2', 'joint4'], SkipReason.DUPLICATE_JOINT),
    (['joint1', 'joint2', 'joint3', 'joint4', 'joint1'], SkipReason.DUPLICATE_JOINT),
    (['joint1', 'joint2', 'joint3', 'gripper'], SkipReason.UNKNOWN_JOINT),
    (['joint1', 'joint2', 'joint3', 'joint4', 'gripper'], SkipReason.UNKNOWN_JOINT),
    (['joint1', 'joint2', 'joint4'], SkipReason.MISSING_JOINT),
    ([], SkipReason.MISSING_JOINT),
])
def test_bad_names_are_refused_with_their_reason(names: list[str], reason: SkipReason) -> None:
    assert JointMap(NAMES).permutation(names) is reason


def test_order_adopted_from_a_message() -> None:
    joint_map = JointMap(n_joints=3)
    assert joint_map.names is None and joint_map.n_joints == 3
    assert joint_map.permutation(['a', 'b']) is SkipReason.JOINT_COUNT
    assert joint_map.permutation(['a', 'b', 'a']) is SkipReason.DUPLICATE_JOINT
    perm = joint_map.permutation(['c', 'a', 'b'])
    assert isinstance(perm, np.ndarray) and perm.tolist() == [0, 1, 2]
    assert joint_map.names is None  # checking adopts nothing
    joint_map.adopt(['c', 'a', 'b'])
    assert joint_map.names == ('c', 'a', 'b')
    perm = joint_map.permutation(['a', 'b', 'c'])
    assert isinstance(perm, np.ndarray) and perm.tolist() == [2, 0, 1]
    with pytest.raises(ValueError, match='configured already'):
        joint_map.adopt(['a', 'b', 'c'])


def test_any_joint_count() -> None:
    names = [f'j{i}' for i in range(7)]
    perm = JointMap(names).permutation(names[::-1])
    assert isinstance(perm, np.ndarray) and perm.tolist() == list(range(6, -1, -1))


@pytest.mark.parametrize('names, n_joints', [
    (['a', 'a'], None), ([], None), (['a', 'b'], 3),
])
def test_bad_configuration_is_refused(names: list[str], n_joints: int | None) -> None:
    with pytest.raises(ValueError, match='rejected'):
        JointMap(names, n_joints=n_joints)
