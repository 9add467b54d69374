"""Tests of the validation of one joint-state sample."""
from __future__ import annotations

import array
import math

import numpy as np
import pytest

from scara_ident_ros.identification import Bounds, JointMap, Sample, SampleCheck, SkipReason
from scara_ident_ros.identification.sample_check import PERIOD_SAMPLES, RESTART_SAMPLES

NAMES = ['joint1', 'joint2', 'joint3']
T0 = 1_000_000_000_000  # ns
MS = 1_000_000  # ns


def make_check(need_effort: bool = True, names: list[str] | None = NAMES) -> SampleCheck:
    return SampleCheck(JointMap(names, n_joints=3), need_effort=need_effort,
                       max_gap_ns=50 * MS)


def good(check: SampleCheck, stamp: int) -> Sample:
    """A valid sample whose effort moves with its stamp (so that it repeats nothing)."""
    moved = (stamp - T0) / MS * 1e-3
    sample = check.check(stamp, NAMES, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0],
                         [7.0 + moved, 8.0, 9.0])
    assert isinstance(sample, Sample)
    return sample


def test_a_good_sample_in_joint_order() -> None:
    sample = good(make_check(), T0)
    assert sample.stamp_ns == T0 and not sample.gap
    assert sample.position.tolist() == [1.0, 2.0, 3.0]
    assert sample.velocity.tolist() == [4.0, 5.0, 6.0]
    assert sample.effort is not None and sample.effort.tolist() == [7.0, 8.0, 9.0]


def test_reordered_message_is_mapped_by_name() -> None:
    check = make_check()
    sample = check.check(T0, ['joint3', 'joint1', 'joint2'], array.array('d', [3, 1, 2]),
                         np.array([6.0, 4.0, 5.0]), (9.0, 7.0, 8.0))
    assert isinstance(sample, Sample)
    assert sample.position.tolist() == [1.0, 2.0, 3.0]
    assert sample.velocity.tolist() == [4.0, 5.0, 6.0]
    assert sample.effort is not None and sample.effort.tolist() == [7.0, 8.0, 9.0]


NAN, INF = math.nan, math.inf


@pytest.mark.parametrize('names, position, velocity, effort, reason', [
    (NAMES, [1, NAN, 3], [4, 5, 6], [7, 8, 9], SkipReason.NON_FINITE),
    (NAMES, [1, 2, 3], [4, 5, INF], [7, 8, 9], SkipReason.NON_FINITE),
    (NAMES, [1, 2, 3], [4, 5, 6], [-INF, 8, 9], SkipReason.NON_FINITE),
    (NAMES, [1, 2, 3], [], [7, 8, 9], SkipReason.NO_VELOCITY),
    (NAMES, [], [4, 5, 6], [7, 8, 9], SkipReason.NO_POSITION),
    (NAMES, [1, 2, 3], [4, 5, 6], [], SkipReason.NO_EFFORT),
    (NAMES, [1, 2], [4, 5, 6], [7, 8, 9], SkipReason.LENGTH_MISMATCH),
    (NAMES, [1, 2, 3], [4, 5, 6, 0], [7, 8, 9], SkipReason.LENGTH_MISMATCH),
    (NAMES, [1, 2, 3], [4, 5, 6], [7, 8], SkipReason.LENGTH_MISMATCH),
    (['joint1', 'joint2', 'jointX'], [1, 2, 3], [4, 5, 6], [7, 8, 9], SkipReason.UNKNOWN_JOINT),
    (['joint1', 'joint2'], [1, 2], [4, 5], [7, 8], SkipReason.MISSING_JOINT),
    (['joint1', 'joint1', 'joint3'], [1, 2, 3], [4, 5, 6], [7, 8, 9],
     SkipReason.DUPLICATE_JOINT),
])
def test_rejections_leave_no_trace(names: list[str], position: list[float],
                                   velocity: list[float], effort: list[float],
                                   reason: SkipReason) -> None:
    check = make_check()
    good(check, T0)
    assert check.check(T0 + MS, names, position, velocity, effort) is reason
    assert check.last_stamp_ns == T0
    sample = good(check, T0 + MS)  # the same stamp is still free
    assert not sample.gap


def test_stamps_must_increase() -> None:
    check = make_check()
    good(check, T0)
    assert check.check(T0, NAMES, [1, 2, 3], [4, 5, 6], [7, 8, 9]) is SkipReason.STAMP_REPEATED
    assert check.check(T0 - 1, NAMES, [1, 2, 3], [4, 5, 6],
                       [7, 8, 9]) is SkipReason.STAMP_BACKWARDS
    assert check.check(T0 - 50 * MS, NAMES, [1, 2, 3], [4, 5, 6],
                       [7, 8, 9]) is SkipReason.STAMP_BACKWARDS
    assert not good(check, T0 + 1).gap


def test_a_clock_jump_either_way_is_a_gap() -> None:
    check = make_check()
    good(check, T0)
    assert not good(check, T0 + 50 * MS).gap  # exactly max_gap: still continuous
    assert good(check, T0 + 101 * MS).gap
    assert not good(check, T0 + 102 * MS).gap
    # a simulator restarted: a jump back of more than max_gap, confirmed by the samples
    # after it (RESTART_SAMPLES in a row), is a restarted clock; the first are refused
    for k in range(RESTART_SAMPLES - 1):
        assert check.check(T0 + k * MS, NAMES, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0],
                           [7.0, 8.0, 9.0]) is SkipReason.STAMP_BACKWARDS
    assert good(check, T0 + (RESTART_SAMPLES - 1) * MS).gap
    assert not good(check, T0 + RESTART_SAMPLES * MS).gap
    check.reset()
    assert not good(check, T0 - 10**12).gap  # after a reset, any time is a fresh start


def test_one_stamp_far_back_is_refused_and_does_not_restart_the_clock() -> None:
    """A bad stamp 0.5 s back between good samples is a missing sample, not a restart."""
    check = make_check()
    for k in range(5):
        assert not good(check, T0 + k * MS).gap
    assert check.check(T0 - 500 * MS, NAMES, [1.0, 2.0, 3.0], [4.0, 5.0, 6.0],
                       [7.0, 8.0, 9.0]) is SkipReason.STAMP_BACKWARDS
    assert not good(check, T0 + 6 * MS).gap  # the next good sample continues the history
    assert check.last_stamp_ns == T0 + 6 * MS


def test_what_counts_as_a_gap_scales_with_the_observed_period() -> None:
    """20 ms is 20 lost samples at 1 kHz but one at 100 Hz: a gap is also > 5 periods."""
    check = SampleCheck(JointMap(NAMES, n_joints=3), max_gap_ns=20 * MS)
    stamp = T0
    good(check, stamp)
    assert good(check, stamp + 30 * MS).gap  # no period observed yet: max_gap alone
    stamp += 30 * MS
    for _ in range(PERIOD_SAMPLES):  # 100 Hz
        stamp += 10 * MS
        assert not good(check, stamp).gap
    assert check.period_ns == 10 * MS and check.gap_ns == 50 * MS
    assert not good(check, stamp + 30 * MS).gap  # two samples lost: bridged
    stamp += 30 * MS
    assert check.check(stamp - 40 * MS, NAMES, [1, 2, 3], [4, 5, 6], [7, 8, 9]) is \
        SkipReason.STAMP_BACKWARDS
    assert good(check, stamp + 51 * MS).gap
    check.reset()
    assert check.period_ns is None and check.gap_ns == 20 * MS
    # at 1 kHz, jittered, the threshold stays max_gap
    rng = np.random.default_rng(0)
    stamps = T0 + np.arange(200) * MS + rng.integers(-300_000, 300_000, 200)
    assert not any(good(check, int(t)).gap for t in stamps)
    assert 0.9 * MS < (check.period_ns or 0) < 1.1 * MS and check.gap_ns == 20 * MS
    assert good(check, int(stamps[-1]) + 21 * MS).gap


def test_effort_is_optional_when_not_required_but_checked_when_present() -> None:
    check = make_check(need_effort=False)
    sample = check.check(T0, NAMES, [1, 2, 3], [4, 5, 6], [])
    assert isinstance(sample, Sample) and sample.effort is None
    # NaN: a joint_state_broadcaster's "no effort interface on this joint"
    sample = check.check(T0 + MS, NAMES, [1, 2, 3], [4, 5, 6], [7, NAN, 9])
    assert isinstance(sample, Sample) and sample.effort is None
    assert sample.position.tolist() == [1.0, 2.0, 3.0]
    assert check.check(T0 + 2 * MS, NAMES, [1, 2, 3], [4, 5, 6], [7, INF, NAN]) is \
        SkipReason.NON_FINITE
    assert check.check(T0 + 2 * MS, NAMES, [1, NAN, 3], [4, 5, 6], [7, NAN, 9]) is \
        SkipReason.NON_FINITE
    assert check.check(T0 + 2 * MS, NAMES, [1, 2, 3], [4, 5, 6], [7]) is \
        SkipReason.LENGTH_MISMATCH
    required = make_check(need_effort=True)
    for effort in ([], [7, NAN, 9], [NAN, NAN, NAN]):
        assert required.check(T0, NAMES, [1, 2, 3], [4, 5, 6], effort) is \
            SkipReason.NO_EFFORT
    assert required.last_stamp_ns is None


def test_joint_order_adopted_from_the_first_valid_message_only() -> None:
    check = make_check(names=None)
    assert check.check(T0, ['b', 'a', 'c'], [1, 2, NAN], [4, 5, 6],
                       [7, 8, 9]) is SkipReason.NON_FINITE
    assert check.joint_map.names is None
    assert check.check(T0, ['a', 'b'], [1, 2], [4, 5], [7, 8]) is SkipReason.JOINT_COUNT
    assert isinstance(check.check(T0, ['c', 'a', 'b'], [1, 2, 3], [4, 5, 6], [7, 8, 9]), Sample)
    assert check.joint_map.names == ('c', 'a', 'b')
    sample = check.check(T0 + MS, ['a', 'b', 'c'], [2, 3, 1], [5, 6, 4], [8, 9, 7.5])
    assert isinstance(sample, Sample) and sample.position.tolist() == [1.0, 2.0, 3.0]


def test_max_gap_must_be_positive() -> None:
    with pytest.raises(ValueError, match='max_gap_ns'):
        SampleCheck(JointMap(NAMES), max_gap_ns=0)


def test_values_beyond_the_limits_are_refused_and_change_nothing() -> None:
    bounds = Bounds.from_limits(np.array([-1.0, 0.0]), np.array([1.0, 0.2]),
                                np.array([2.0, 1.0]), np.array([10.0, 100.0]), margin=0.5)
    np.testing.assert_allclose(bounds.lo, [[-2.0, -0.1], [-3.0, -1.5], [-15.0, -150.0]])
    check = SampleCheck(JointMap(('a', 'b'), n_joints=2), bounds=bounds)
    good = check.check(1, ('a', 'b'), [1.9, 0.25], [-2.9, 1.4], [14.0, -149.0])
    assert not isinstance(good, SkipReason)
    for position, velocity, effort in [([1e6, 0.1], [0, 0], [0, 0]),   # 1e6 rad
                                       ([0, 0.31], [0, 0], [0, 0]),   # beyond the margin
                                       ([0, 0.1], [0, -1.6], [0, 0]),
                                       ([0, 0.1], [0, 0], [16.0, 0])]:
        assert check.check(2, ('a', 'b'), position, velocity, effort) is \
            SkipReason.OUT_OF_LIMITS
        assert check.last_stamp_ns == 1  # nothing changed
    # reordered joints are bounded by name, and an empty effort is not checked
    check = SampleCheck(JointMap(('a', 'b'), n_joints=2), need_effort=False, bounds=bounds)
    assert check.check(3, ('b', 'a'), [0.25, 1.9], [1.4, -2.9], []).effort is None
    assert check.check(4, ('b', 'a'), [1.9, 0.25], [0, 0], []) is SkipReason.OUT_OF_LIMITS


def test_a_state_sent_again_under_a_new_stamp_is_repeated() -> None:
    check = make_check()
    first = good(check, T0)
    again = (NAMES, first.position, first.velocity, first.effort)
    assert check.check(T0 + MS, *again) is SkipReason.REPEATED
    assert check.last_stamp_ns == T0  # refused: nothing changed
    reordered = (['joint3', 'joint1', 'joint2'], [3.0, 1.0, 2.0], [6.0, 4.0, 5.0],
                 [9.0, 7.0, 8.0])
    assert check.check(T0 + 2 * MS, *reordered) is SkipReason.REPEATED  # compared by name
    assert not good(check, T0 + 3 * MS).gap  # a new state is accepted
    # without effort (a robot without effort sensors, at rest): never refused as repeated
    loose = make_check(need_effort=False)
    for k in range(3):
        assert isinstance(loose.check(T0 + k * MS, NAMES, [1.0, 2.0, 3.0], [0.0, 0.0, 0.0]),
                          Sample)
