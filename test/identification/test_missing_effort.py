"""Samples without a measured effort: predicted and published, never learnt nor scored.

A ros2_control joint_state_broadcaster fills NaN for a joint without an effort interface,
and some drivers publish no effort at all.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from scara_ident_ros.identification import (Holdout, OnlineIdentifier, ReservoirLM,
                                            SkipReason)
from scara_ident_ros.nn.presets import make_network

NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
T0 = 1_700_000_000_000_000_000  # ns
MS = 1_000_000  # ns


def state(k: int) -> tuple[list[float], list[float], list[float]]:
    """Sample k: q, q' smooth in k (q'' exact), effort linear in k."""
    t = k * 1e-3  # s
    q = [0.1 * math.sin(t + j) for j in range(4)]
    qd = [0.1 * math.cos(t + j) for j in range(4)]
    return q, qd, [j - 0.01 * k for j in range(4)]


@pytest.mark.parametrize('learn', [True, False])
def test_missing_effort_is_predicted_not_learnt_and_counted(learn: bool) -> None:
    net = make_network('ffs', 4, n_hidden=5, seed=0)
    trainer = ReservoirLM(net, reservoir_size=100, lm_interval=10)
    ident = OnlineIdentifier(net, joint_names=NAMES, trainer=trainer, learn=learn,
                             holdout=Holdout(12, 4, fraction=0.5, block=10, seed=1))
    unmeasured: set[int] = set()
    results = []
    for k in range(200):
        q, qd, effort = state(k)
        if k % 7 == 3:
            effort = []  # no effort at all
            unmeasured.add(T0 + k * MS)
        elif k % 7 == 5:
            effort[1] = math.nan  # joint2 has no effort interface
            unmeasured.add(T0 + k * MS)
        results += ident.process(T0 + k * MS, NAMES, q, qd, effort)
    results += ident.finish()
    counts = ident.counts
    assert all(r.reason in (None, SkipReason.WARMING_UP) for r in results)
    published = [r for r in results if r.effort is not None]
    assert len(published) == counts.predicted == 200
    assert all(np.isfinite(r.effort).all() for r in published if r.effort is not None)
    assert counts.no_effort == len(unmeasured) == 57
    assert sum(counts.skipped.values()) == 0
    # never held out, learnt or scored
    assert not any(r.held_out for r in published if r.stamp_ns in unmeasured)
    assert len(ident.holdout.reservoir) == counts.held_out  # type: ignore[union-attr]
    assert ident.errors.count == 200 - 57
    if learn:
        assert counts.learnt + counts.held_out + counts.refused + counts.no_effort == 200
        assert len(trainer.reservoir) == min(100, counts.learnt)
        assert counts.learnt > 0
    else:
        assert counts.learnt == 0 and len(trainer.reservoir) == 0
