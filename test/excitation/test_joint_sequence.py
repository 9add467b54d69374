"""The sequence for any joints is the simulator's sequence: same seeds, same blends."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES, JointLimits
from scara_ident_ros.excitation import JointSequence
from scara_ident_ros.sim.sequence import SequenceTrajectory

CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'scara.yaml'


def scara_limits(params: ScaraParams) -> JointLimits:
    return JointLimits.of(params.joint_names, {key: params.array(key) for key in LIMIT_NAMES},
                          'scara.yaml')


@pytest.mark.parametrize('seed', [0, 7])
def test_on_the_scara_it_is_the_simulators_sequence(seed: int) -> None:
    # efforts that never bind: the simulator's sequence then checks what this one checks
    params = replace(ScaraParams.from_yaml(CONFIG), effort_max=(1e9,) * 4)
    expected = SequenceTrajectory(params, seed=seed)
    sequence = JointSequence(scara_limits(params), seed=seed)
    t = np.linspace(0.0, 42.0, 8401)  # 8 joins
    for ours, theirs in zip(sequence.evaluate(t), expected.evaluate(t)):
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12)


def test_any_number_of_joints_keeps_to_the_blend_fractions() -> None:
    n = 6
    limits = JointLimits(tuple(f'j{i}' for i in range(n)), -np.arange(1, n + 1.0),
                         np.arange(1, n + 1.0) * 0.5, np.full(n, 2.0),
                         np.linspace(3.0, 20.0, n), np.full(n, 10.0))
    sequence = JointSequence(limits, seed=3)
    t = np.arange(0.0, 30.0, 0.002)
    q, qd, qdd = sequence.evaluate(t)
    assert q.shape == qd.shape == qdd.shape == (t.size, n)
    half = 0.5 * (limits.position_max - limits.position_min)
    assert np.all(np.abs(q - limits.centre) <= 0.8 * half + 1e-9)
    assert np.all(np.abs(qd) <= 0.8 * limits.velocity_max * (1 + 1e-3))
    assert np.all(np.abs(qdd) <= 0.8 * limits.acceleration_max * (1 + 1e-3))
    # it does move: every joint uses a good part of what it may
    assert np.all(np.abs(qd).max(axis=0) > 0.3 * limits.velocity_max)
    again = JointSequence(limits, seed=3).evaluate(t[::-1])[0][::-1]
    np.testing.assert_array_equal(again, q)
    assert not np.allclose(JointSequence(limits, seed=4).evaluate(t)[0], q)
