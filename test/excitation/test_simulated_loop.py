"""The loop simulated in one process: the node's plan and chunks, followed by the simulated
SCARA, which holds, tracks the plan and, with no margins, moves as its own sequence does."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.excitation import LoopSettings
from scara_ident_ros.excitation.simulated_loop import simulate_loop
from scara_ident_ros.paper.datasets import simulate_record

ROOT = Path(__file__).resolve().parents[2]
S = 1_000_000_000  # ns


@pytest.fixture(scope='module')
def params() -> ScaraParams:
    return ScaraParams.from_yaml(ROOT / 'config' / 'scara.yaml')


def test_the_settings_default_to_the_nodes_parameters() -> None:
    # the node's defaults, as config/excitation.yaml holds them (test/nodes checks it does)
    config = yaml.safe_load((ROOT / 'config' / 'excitation.yaml').read_text())
    defaults = config['/**']['ros__parameters']
    for field in dataclasses.fields(LoopSettings):
        assert field.default == defaults[field.name], field.name


def test_the_arm_holds_then_tracks_the_plan_within_the_margins(params: ScaraParams,
                                                               limits: JointLimits) -> None:
    settings = LoopSettings(seed=3)
    loop = simulate_loop(params, limits, seconds=4.0, settings=settings)
    record, t = loop.record, loop.plan_times()
    assert len(record) == 4000 and record.stamp_ns[0] == 0
    assert loop.origin_ns == round(settings.start_delay * S)
    assert loop.chunks == 16  # one every 0.25 s from the first sample
    held = t < 0.0
    np.testing.assert_allclose(record.q[held], np.tile(params.position_centre,
                                                       (held.sum(), 1)), rtol=0, atol=1e-9)
    moving = ~held
    q, qd, qdd = loop.plan.evaluate(t[moving])
    assert np.all(np.abs(record.q[moving] - q).max(axis=0) < 5e-3)
    assert np.ptp(record.q[moving], axis=0).min() > 0.01  # it moved
    margined = limits.with_margins(settings.position_margin, settings.velocity_scale,
                                   settings.acceleration_scale)
    assert margined.violations(q, qd, qdd, position_hull=params.position_centre) == []


def test_without_margins_the_loop_moves_as_the_simulators_own_sequence(
        params: ScaraParams, limits: JointLimits) -> None:
    """Scales 1/1 and no position margin: after the start delay and the approach, the arm
    follows the simulator's own ``sequence`` of the same seed (the same excitation), so the
    two streams differ by a shift in time only."""
    settings = LoopSettings(position_margin=0.0, velocity_scale=1.0, acceleration_scale=1.0,
                            seed=1)
    loop = simulate_loop(params, limits, seconds=6.0, settings=settings)
    shift = loop.origin_ns + round(loop.plan.approach_duration * S)
    own = simulate_record(params, seconds=6.0, seed=1, preset='sequence')
    after = loop.record.stamp_ns >= shift + S  # a second to settle on the sequence
    index = np.searchsorted(own.stamp_ns, loop.record.stamp_ns[after] - shift)
    gap = np.abs(loop.record.q[after] - own.q[index]).max(axis=0)
    assert np.all(gap < 5e-3), gap
    assert np.ptp(own.q[index], axis=0).min() > 0.01


def test_limits_of_other_joints_are_refused(params: ScaraParams,
                                            limits: JointLimits) -> None:
    other = dataclasses.replace(limits, names=('a', 'b', 'c', 'd'))
    with pytest.raises(ValueError, match='limits of'):
        simulate_loop(params, other, seconds=0.1)
