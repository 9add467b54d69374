"""The core built for the first valid sample's joints, with the samples before it counted."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.identification import (IdentifierSettings, LazyCore, SkipReason,
                                            Skipped, make_differentiator)
from scara_ident_ros.nn.presets import make_network

NAMES = ['a', 'b']
LIMITS = JointLimits.of(NAMES, {
    'position_min': [-1.0, 0.0], 'position_max': [1.0, 0.5], 'velocity_max': [2.0, 1.0],
    'acceleration_max': [10.0, 5.0], 'effort_max': [20.0, 100.0]})
SETTINGS = IdentifierSettings.defaults(
    method='ffs', hidden_units=5, trainer='bp', reservoir_size=100, lm_steps=1,
    lm_interval=10, validation_fraction=0.0, validation_block=10, mse_window=100)
MS = 1_000_000  # ns


def first(lazy: LazyCore, names: list[str], stamp_ms: int = 1,
          settings: IdentifierSettings = SETTINGS, effort: list[float] | None = None
          ) -> Skipped | None:
    n = len(names)
    return lazy.first(settings, make_differentiator('centred', window=5), stamp_ms * MS,
                      names, [0.1] * n, [0.0] * n, [1.0] * n if effort is None else effort)


def test_the_first_valid_sample_builds_and_the_early_ones_are_counted() -> None:
    lazy = LazyCore(LIMITS)
    skipped = first(lazy, ['a', 'a'])
    assert skipped is not None and skipped.reason is SkipReason.DUPLICATE_JOINT
    skipped = first(lazy, ['a', 'z'], 2)  # valid, but z has no limits
    assert skipped is not None and skipped.reason is SkipReason.UNKNOWN_JOINT
    assert "no joint limits for ['z']" in skipped.note
    assert lazy.core is None and lazy.counts is lazy.early and lazy.early.processed == 2
    assert first(lazy, ['b', 'a'], 3, effort=[]) is None  # no effort: still fixes the joints
    assert lazy.core is not None and lazy.names == ['b', 'a']
    assert lazy.network is not None and lazy.network.activation == 'sigmoid'
    assert list(lazy.network.metadata['joint_names']) == ['b', 'a']
    assert lazy.counts.processed == 2
    assert lazy.counts.skipped[SkipReason.DUPLICATE_JOINT] == 1
    assert lazy.counts.skipped[SkipReason.UNKNOWN_JOINT] == 1
    assert lazy.core.stage.check.bounds is not None
    lazy.reset()
    assert (lazy.core, lazy.network, lazy.names, lazy.counts.processed) == (None, None, [], 0)


def test_min_joints_waits_for_a_message_naming_enough() -> None:
    lazy = LazyCore(LIMITS)
    settings = SETTINGS.replace(min_joints=2)
    skipped = first(lazy, ['a'], settings=settings)
    assert skipped is not None and skipped.reason is SkipReason.JOINT_COUNT
    assert skipped.note == ("waiting for a message naming at least 2 joints (min_joints); "
                            "this one names ['a']")
    assert first(lazy, NAMES, 2, settings=settings) is None


def test_a_warm_start_needs_its_joint_count_not_limits() -> None:
    network = make_network('ffs', 3, n_hidden=4)
    lazy = LazyCore(LIMITS, network)
    skipped = first(lazy, NAMES)
    assert skipped is not None and skipped.reason is SkipReason.JOINT_COUNT
    assert first(lazy, ['x', 'y', 'z'], 2) is None
    assert lazy.network is network and lazy.names == ['x', 'y', 'z']
    assert lazy.core is not None and lazy.core.stage.check.bounds is None  # no limits known


@pytest.mark.parametrize('margin', [-1.0, 0.5])
def test_a_negative_margin_bounds_nothing(margin: float) -> None:
    lazy = LazyCore(LIMITS)
    settings = SETTINGS.replace(limit_margin=margin)
    assert lazy.build(NAMES, settings, make_differentiator('centred', window=5)) == ''
    assert lazy.core is not None
    assert (lazy.core.stage.check.bounds is None) == (margin < 0)


@pytest.mark.parametrize('trainer, steps', [('lm', True), ('bp', False)])
def test_the_lm_trainers_network_starts_with_friction_steps(trainer: str, steps: bool) -> None:
    """``lm_friction_steps`` shapes the lm trainer's fresh network; the paper's bp keeps
    all-random weights."""
    lazy = LazyCore(LIMITS)
    settings = SETTINGS.replace(trainer=trainer)
    assert first(lazy, NAMES, settings=settings) is None
    assert lazy.network is not None
    Vt = lazy.network.unpack(lazy.network.theta)[0]
    # 5 hidden units, 2 joints: the widest step of each joint's speed (inputs 2, 3)
    single = [np.count_nonzero(Vt[:6, unit]) == 1 and Vt[2 + unit % 2, unit] != 0.0
              for unit in range(2)]
    assert all(single) if steps else not any(single)
