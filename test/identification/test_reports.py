"""The reports' JSON keys (what a stats_file holds and its readers use) and their spelling."""
from __future__ import annotations

import dataclasses
import json

from scara_ident_ros.identification.reports import (ContactState, HealthFigures,
                                                    LearningFigures, MethodReport, SkipCounts,
                                                    StreamFigures)
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.nodes.health import Level, identifier_health

#: what the stats_file's readers (cli/run.py, benchmarks, tests) take from it
STATS_KEYS = {
    'method', 'trainer', 'joint_names', 'processed', 'predicted', 'learnt', 'held_out',
    'refused', 'clipped', 'no_effort', 'pending', 'skipped', 'skipped_total', 'mse', 'nmse',
    'mse_total', 'nmse_total', 'validation_nmse', 'validation_nmse_total', 'contacts',
    'contact_armed', 'contact_thresholds', 'contact_held', 'contact_delay_p50_ms',
    'contact_delay_p99_ms', 'worst_lag_ms', 'lag_p50_ms', 'lag_p99_ms'}
STREAM_KEYS = {'lost', 'pauses', 'paused_s', 'path_delay_p50_ms', 'path_delay_p99_ms',
               'wall_clock_stamps', 'joint_states_publishers', 'stamps_backward'}
LEARNING_KEYS = {'updates', 'updates_per_s', 'lm_steps_taken', 'learn_dropped'}


def report(**changes: object) -> MethodReport:
    counts = dict.fromkeys(SkipReason, 0)
    counts.update({SkipReason.WARMING_UP: 2, SkipReason.GAP: 3})
    base = MethodReport(
        method='ffs', trainer='lm', joint_names=('j1', 'j2'), processed=100, predicted=93,
        learnt=80, held_out=13, pending=2, skipped=SkipCounts.of(counts),
        mse=(1.0, 2.0), nmse=(0.1, 0.2), mse_total=1.5, nmse_total=0.15,
        validation_nmse=(0.3, 0.4), validation_nmse_total=0.35, worst_lag_ms=4.0)
    return dataclasses.replace(base, **changes)  # type: ignore[arg-type]


def test_skipped_is_always_per_reason_with_a_total() -> None:
    counts = dict.fromkeys(SkipReason, 0)
    counts[SkipReason.REPEATED] = 4
    counts[SkipReason.GAP] = 1
    skipped = SkipCounts.of(counts)
    assert skipped.as_dict() == {'repeated': 4, 'gap': 1}  # reasons with none left out
    assert skipped.total == 5 and SkipCounts().total == 0
    assert str(skipped) == 'repeated 4, gap 1' and str(SkipCounts()) == 'none'


def test_the_stats_file_keys_one_spelling_per_figure() -> None:
    data = report().as_dict()
    assert set(data) == STATS_KEYS
    assert data['skipped'] == {'warming_up': 2, 'gap': 3} and data['skipped_total'] == 5
    assert data['validation_nmse'] == [0.3, 0.4] and data['validation_nmse_total'] == 0.35
    assert data['learnt'] == 80 and data['joint_names'] == ['j1', 'j2']
    # accounting: processed = predicted + skipped + pending
    assert data['processed'] == data['predicted'] + data['skipped_total'] + data['pending']
    assert json.loads(json.dumps(data)) == data  # plain JSON


def test_stream_learning_and_previous_reports_go_inline() -> None:
    before = report(stream=StreamFigures(lost=3))
    after = report(stream=StreamFigures(lost=1, paused_s=0.5),
                   learning=LearningFigures(updates=7, updates_per_s=2.5, lm_steps_taken=21,
                                            learn_dropped=0),
                   previous=(before,))
    data = after.as_dict()
    assert set(data) == STATS_KEYS | STREAM_KEYS | LEARNING_KEYS | {'previous'}
    assert data['lost'] == 1 and data['updates'] == 7 and data['paused_s'] == 0.5
    previous, = data['previous']
    assert previous['lost'] == 3 and 'previous' not in previous


def test_a_report_before_any_model_has_the_counters_and_no_errors() -> None:
    early = MethodReport(method='hybrid', processed=3, skipped=SkipCounts({'no_velocity': 3}))
    data = early.as_dict()
    assert data['processed'] == data['skipped_total'] == 3 and data['predicted'] == 0
    assert data['validation_nmse'] is None and data['mse_total'] is None


def test_health_figures_are_the_keywords_of_identifier_health() -> None:
    figures = HealthFigures(processed=1000, learnt=900, skipped=SkipCounts({'gap': 2}),
                            period_worst_lag_ms=3.0, error_finite=True,
                            validation_nmse_total=0.05, learning=True,
                            contact=ContactState(why_not='no model yet'))
    health = identifier_health(period_s=1.0, since_sample_s=0.001, lost=0,
                               recent_processed=1000, recent_skipped=0, recent_lost=0,
                               **figures.as_dict())
    assert health.level is Level.OK
    assert health.values['skipped'] == '2' and health.values['learnt'] == '900'
    assert health.values['lag [ms]'] == '3' and health.values['validation NMSE'] == '0.05'
    assert health.values['contact detection'] == 'not armed (no model yet)'
