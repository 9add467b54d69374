"""The diagnostics levels of :mod:`scara_ident_ros.nodes.health` follow the conditions."""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from scara_ident_ros.nodes.health import (LOSS_HORIZON, Deltas, Level, LossCounter,
                                                   identifier_health, recorder_health,
                                                   simulator_health)
from scara_ident_ros.sim.jitter import StampJitter

MS = 1_000_000  # ns


def healthy_identifier(**changes: Any) -> dict[str, Any]:
    """An identifier's figures over a 1 s period at 1 kHz with nothing wrong, changed."""
    figures: dict[str, Any] = {
        'period_s': 1.0, 'since_sample_s': 0.001, 'processed': 5000, 'skipped_total': 10,
        'lost': 0, 'learnt': 4500, 'recent_processed': 1000, 'recent_skipped': 0, 'recent_lost': 0,
        'period_worst_lag_ms': 12.0, 'error_finite': True, 'validation_nmse_total': 0.05,
        'learning': True}
    figures.update(changes)
    return figures


def test_identifier_ok_reports_its_figures() -> None:
    health = identifier_health(**healthy_identifier())
    assert health.level is Level.OK
    assert health.message == 'identifying at 1000 samples/s, learning on'
    assert health.values == {'samples/s': '1000.0', 'lag [ms]': '12', 'processed': '5000',
                             'skipped': '10', 'lost': '0', 'learnt': '4500',
                             'learning': 'true', 'validation NMSE': '0.05'}


def test_identifier_says_whether_contact_detection_is_armed() -> None:
    armed = identifier_health(**healthy_identifier(), contact_armed=True,
                              contact_thresholds=[12.5, 5.25, 13.0, 0.5],
                              contact_arm_nmse=0.01)
    assert armed.level is Level.OK
    assert armed.values['contact detection'] == 'armed'
    assert armed.values['contact thresholds'] == '12.5, 5.25, 13, 0.5'
    waiting = identifier_health(**healthy_identifier(), contact_armed=False,
                                contact_thresholds=None, contact_arm_nmse=0.01)
    assert waiting.values['contact detection'] == 'not armed (until validation NMSE < 0.01)'
    assert waiting.values['contact thresholds'] == 'none yet'


def test_identifier_diagnostics_say_why_not_armed_the_rate_and_the_delay() -> None:
    health = identifier_health(**healthy_identifier(), contact_armed=False,
                               contact_thresholds=[1.0, 2.0], contact_arm_nmse=0.01,
                               contact_why_not='5 independent held-out draws, need 8',
                               contact_false_alarms_per_hour=0.5, contact_segments=5.0,
                               contact_held=7, contact_delay_p50_ms=11.0,
                               contact_delay_p99_ms=23.0)
    values = health.values
    assert values['contact detection'].startswith(
        'not armed (5 independent held-out draws, need 8); 7 samples held')
    assert values['contact false alarms/h (estimated)'] == '0.5'
    assert values['contact independent segments'] == '5'
    assert values['contact held (outside envelope)'] == '7'
    assert values['contact delay p50 / p99 [ms]'] == '11 / 23'
    quiet = identifier_health(**healthy_identifier(), contact_armed=True,
                              contact_thresholds=[1.0], contact_arm_nmse=0.01)
    assert quiet.values['contact detection'] == 'armed'
    assert quiet.values['contact delay p50 / p99 [ms]'] == 'n/a / n/a'


@pytest.mark.parametrize(('changes', 'level', 'words'), [
    ({'since_sample_s': 1.5, 'recent_processed': 0}, Level.WARN, 'no sample for 1.5 s (> 1 s)'),
    ({'since_sample_s': None, 'recent_processed': 0}, Level.WARN, 'no sample received yet'),
    ({'recent_skipped': 200}, Level.WARN, '20% of the samples skipped (> 10%)'),
    ({'validation_nmse_total': 1.2}, Level.WARN, 'validation NMSE 1.2 > 1'),
    ({'recent_lost': 3, 'lost': 3}, Level.ERROR, '3 samples lost in the last 1.0 s'),
    ({'update_overdue_s': 12.4}, Level.WARN, 'learning stalled: no update for 12 s'),
    ({'error_finite': False}, Level.ERROR, 'not finite'),
    ({'error_finite': False, 'validation_nmse_total': 2.0}, Level.ERROR, 'worse than the mean'),
])
def test_identifier_levels_follow_the_conditions(changes: dict[str, Any], level: Level,
                                                 words: str) -> None:
    health = identifier_health(**healthy_identifier(**changes))
    assert health.level is level
    assert words in health.message


def test_identifier_thresholds_are_exclusive() -> None:
    at_limits = healthy_identifier(since_sample_s=1.0, recent_skipped=100,
                                   validation_nmse_total=1.0)
    assert identifier_health(**at_limits).level is Level.OK


def test_identifier_without_validation_or_predictions_says_not_available() -> None:
    health = identifier_health(**healthy_identifier(validation_nmse_total=float('nan'),
                                                    period_worst_lag_ms=None))
    assert health.level is Level.OK
    assert health.values['validation NMSE'] == 'n/a'
    assert health.values['lag [ms]'] == 'n/a'


def test_simulator_levels() -> None:
    ok = simulator_health(period_s=1.0, nominal_hz=1000.0, published=3000, late=0,
                          recent_published=1000, recent_late=5, waiting=False)
    assert ok.level is Level.OK and ok.values['samples/s'] == '1000.0'
    late = simulator_health(period_s=1.0, nominal_hz=1000.0, published=3000, late=20,
                            recent_published=1000, recent_late=20, waiting=False)
    assert late.level is Level.WARN and '20 of 1000 samples late (> 1%)' in late.message
    slow = simulator_health(period_s=1.0, nominal_hz=1000.0, published=3000, late=0,
                            recent_published=400, recent_late=0, waiting=False)
    assert slow.level is Level.ERROR and 'less than 50% of 1000 Hz' in slow.message
    waiting = simulator_health(period_s=1.0, nominal_hz=1000.0, published=0, late=0,
                               recent_published=0, recent_late=0, waiting=True)
    assert waiting.level is Level.OK and waiting.message == 'waiting for subscribers'
    as_fast = simulator_health(period_s=1.0, nominal_hz=0.0, published=10, late=0,
                               recent_published=10, recent_late=0, waiting=False)
    assert as_fast.level is Level.OK


def test_recorder_warns_while_paused() -> None:
    figures: dict[str, Any] = {'period_s': 2.0, 'written': 100, 'received': 150, 'paused': 50,
                               'recent_written': 100, 'files': 2, 'topics': 3}
    running = recorder_health(is_paused=False, **figures)
    assert running.level is Level.OK and running.values['write rate [msg/s]'] == '50.0'
    assert running.values['not written (paused)'] == '50'
    paused = recorder_health(is_paused=True, **figures)
    assert paused.level is Level.WARN and '~/resume' in paused.message


def test_deltas_since_the_previous_call() -> None:
    deltas = Deltas()
    assert deltas(a=5, b=1) == {'a': 5, 'b': 1}
    assert deltas(a=7, b=1) == {'a': 2, 'b': 0}
    assert deltas(a=3, b=1) == {'a': 3, 'b': 0}  # a restarted from 0


def test_loss_counter_counts_missing_samples_from_stamp_gaps() -> None:
    counter = LossCounter()
    stamps = [0, 1, 2, 3, 5, 6, 10, 11, 11, 10, 12]  # ms: 4 and 7-9 missing; repeats ignored
    for stamp in stamps:
        counter.observe(stamp * MS)
    assert counter.period_ns == MS
    assert counter.lost == 0 and counter.pending == 4  # counted when the stream is not late
    for stamp in range(13, 13 + LOSS_HORIZON):
        counter.observe(stamp * MS)
    assert counter.lost == 4 and counter.pending == 0
    for stamp in range(57, 57 + 128):  # a slower stream: its period replaces the old one
        counter.observe(stamp * 2 * MS)
    assert counter.period_ns == 2 * MS
    counter.settle()
    lost = counter.lost
    for stamp in range(141, 141 + 50):
        counter.observe(stamp * 2 * MS)
    assert counter.lost == lost


def test_loss_counter_tolerates_jitter_and_ignores_restarts() -> None:
    counter = LossCounter()
    for stamp in [0.0, 1.0, 2.0, 3.4, 4.0, 5.3, 6.0, 5000.0, 5001.0]:  # ms; then 5 s
        counter.observe(round(stamp * MS))
    assert counter.lost == 0


def test_loss_counter_counts_no_loss_in_a_jittered_stream_and_finds_real_ones() -> None:
    # 500 Hz with 0.2 ms of stamp jitter, as scara_sim -p jitter:=0.0002 makes it: the
    # differences reach 1.6 periods, above LOST_GAP alone
    stamps = StampJitter(2 * MS, 0.0002, seed=4).stamps_ns(0, 30_000)
    assert np.diff(stamps).max() > 1.5 * 2 * MS  # the case the jitter term is for
    counter = LossCounter()
    for stamp in stamps:
        counter.observe(int(stamp))
    assert counter.lost == 0
    for jitter, found in ((0.0001, range(30, 31)), (0.0002, range(15, 31))):
        dropped = LossCounter()
        stamps = StampJitter(2 * MS, jitter, seed=4).stamps_ns(0, 30_000)
        for k, stamp in enumerate(stamps):
            if k % 1000 != 500:  # 30 single samples missing
                dropped.observe(int(stamp))
        dropped.settle()
        assert dropped.lost in found  # never more than were lost


def test_late_samples_of_uneven_stamps_are_not_lost_but_missing_ones_are() -> None:
    """A nominal 1 kHz whose stamps step 0.7 to 8.8 ms (a real arm's): a long step
    followed by short ones that catch up is lateness; 5 samples left out are lost."""
    rng = np.random.default_rng(0)
    stamps, t = [], 0.0
    for k in range(20_000):
        late = k % 500 == 250
        t += 8.8 if late else (0.7 if 0 < k % 500 - 250 <= 26 else rng.uniform(0.95, 1.05))
        stamps.append(round(t * MS))
    counter = LossCounter(span_s=0.02, pause_periods=5)
    for stamp in stamps:
        counter.observe(stamp)
    counter.settle()
    assert counter.lost == 0 and counter.pauses == 0
    dropped = LossCounter(span_s=0.02, pause_periods=5)
    for k, stamp in enumerate(stamps):
        if not 10_100 <= k < 10_105:
            dropped.observe(stamp)
    dropped.settle()
    assert dropped.lost == 5


@pytest.mark.parametrize('changes', [{'update_overdue_s': 9.0},
                                     {'update_overdue_s': 60.0, 'learning': False},
                                     {'update_overdue_s': None}])
def test_a_due_update_warns_only_when_learning_and_long_overdue(
        changes: dict[str, Any]) -> None:
    assert identifier_health(**healthy_identifier(**changes)).level is Level.OK
