"""Contact detection: thresholds from a-priori or held-out residuals, arming, the check."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraModel, ScaraParams
from scara_ident_ros.paper.contact import detect, evaluate, pulse_record, residuals_of
from scara_ident_ros.paper.learning_curves import noisy_config
from scara_ident_ros.identification import Holdout, InputStage, JointMap, OnlineIdentifier
from scara_ident_ros.identification.contact_detector import (HELD_OUT, MIN_DRAWS,
                                                             RECENT_CHUNK, ContactDetector,
                                                             correlation_time, robust_spread)
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory


def test_robust_spread_is_a_gaussians_std_and_ignores_outliers() -> None:
    rng = np.random.default_rng(0)
    residuals = rng.normal(0.0, [1.0, 0.1], size=(20_000, 2))
    residuals[:200] = 1e3  # 1 % gross errors barely move the median absolute deviation
    np.testing.assert_allclose(robust_spread(residuals), [1.0, 0.1], rtol=0.05)


def ar1_segments(rng: np.random.Generator, count: int, length: int, rho: float,
                 scale: tuple[float, ...]) -> np.ndarray:
    """Segments (count, length, n) of an AR(1) residual with correlation ``rho`` per sample,
    stationary standard deviation ``scale`` per joint."""
    n = len(scale)
    shocks = rng.normal(size=(count, length, n)) * np.sqrt(1.0 - rho * rho)
    out = np.empty_like(shocks)
    out[:, 0] = rng.normal(size=(count, n))
    for t in range(1, length):
        out[:, t] = rho * out[:, t - 1] + shocks[:, t]
    return out * np.asarray(scale)


def test_the_correlation_time_of_an_ar1_residual() -> None:
    rng = np.random.default_rng(0)
    segments = ar1_segments(rng, 400, 100, 0.9, (1.0, 1.0))
    segments[..., 1] = rng.normal(size=(400, 100))  # white
    tau = correlation_time(segments)
    assert 17 <= tau[0] <= 27  # 0.9 ** lag < 0.1 from lag 22 on
    assert tau[1] == 1


def test_the_false_alarm_rate_on_fresh_free_motion_stays_under_the_bound() -> None:
    """Oracle: an autocorrelated, heavy-tailed (Student t) residual; thresholds from 200
    held-out segments; on 4,000 fresh segments (400 s) the alarms are within the bound."""
    rng = np.random.default_rng(1)
    bound = 100.0  # per hour: 11 alarms allowed in 400 s, so the check can fail

    def residuals(count: int) -> np.ndarray:
        base = ar1_segments(rng, count, 100, 0.8, (1.0, 0.1))
        base[..., 0] *= np.sqrt(3.0 / rng.chisquare(3.0, size=(count, 1)))  # heavy tail
        return base

    detector = ContactDetector(2, false_alarms_per_hour=bound, arm_nmse=0.1, calibrate_on=HELD_OUT)
    calibration = detector.calibrate(residuals(200), 0.001, sample_period_s=1e-3)
    assert detector.armed, calibration.why_not
    assert calibration.false_alarms_per_hour is not None
    assert calibration.false_alarms_per_hour <= bound
    fresh = residuals(4000)
    # a segment (0.1 s) with flags is one alarm at most
    alarms = sum(any(detector.check(row).any() for row in segment) for segment in fresh)
    allowed = bound * 4000 * 0.1 / 3600.0
    assert alarms <= allowed
    # the thresholds of the detector before (12 robust sigmas) fire far more often
    before = 12.0 * robust_spread(fresh.reshape(-1, 2))
    assert np.any(np.abs(fresh) > before, axis=2).any(axis=1).sum() > allowed


def test_armed_only_when_identified_with_enough_independent_segments() -> None:
    rng = np.random.default_rng(2)
    residuals = rng.normal(size=(150, 100, 2))
    detector = ContactDetector(2, arm_nmse=0.01, calibrate_on=HELD_OUT)
    big = np.array([100.0, 100.0])
    assert not detector.armed and not detector.check(big).any()  # not calibrated
    detector.calibrate(residuals, 0.5)  # NMSE above arm_nmse: not identified
    assert detector.thresholds is not None and not detector.armed
    assert 'NMSE' in detector.calibration.why_not
    assert not detector.check(big).any()
    detector.calibrate(residuals[:MIN_DRAWS - 1], 0.001)  # too few segments
    assert not detector.armed and 'segments' in detector.calibration.why_not
    assert not detector.check(big).any()
    # joint 0 correlated beyond a segment, 10 segments from each of 7 blocks: one draw a
    # block, too few, though joint 1 (white) has a draw per segment
    correlated = residuals[:70].copy()
    correlated[..., 0] = ar1_segments(rng, 70, 100, 0.99, (1.0,))[..., 0]
    detector.calibrate(correlated, 0.001, blocks=np.repeat(np.arange(7), 10))
    assert not detector.armed and detector.calibration.independent == 7 < MIN_DRAWS
    assert 'draws' in detector.calibration.why_not
    detector.calibrate(correlated, 0.001, blocks=np.arange(70) // 8)
    assert detector.armed and detector.calibration.independent == 9  # 9 blocks
    detector.calibrate(residuals, None)  # no validation score
    assert not detector.armed
    calibration = detector.calibrate(residuals, 0.001)
    assert detector.armed and calibration.why_not == ''
    assert calibration.false_alarms_per_hour is not None
    assert calibration.false_alarms_per_hour <= detector.false_alarms_per_hour * (1 + 1e-9)
    assert detector.check(np.array([100.0, 0.1])).tolist() == [True, False]
    assert detector.check(np.array([-100.0, np.nan])).tolist() == [True, False]
    detector.update_nmse(0.005)  # still identifies: armed
    assert detector.armed
    detector.update_nmse(0.05)  # the model got worse since: disarmed until recalibrated
    assert not detector.armed and 'NMSE' in detector.calibration.why_not
    assert not detector.check(big).any()
    detector.update_nmse(0.001)
    assert not detector.armed
    detector.calibrate(residuals, 0.001)
    assert detector.armed
    detector.reset()
    assert not detector.armed and not detector.check(big).any()


def test_a_tighter_bound_gives_higher_thresholds() -> None:
    residuals = np.random.default_rng(3).normal(size=(300, 100, 1))
    loose = ContactDetector(1, false_alarms_per_hour=100.0, sigma=0.1, calibrate_on=HELD_OUT)
    tight = ContactDetector(1, false_alarms_per_hour=0.01, sigma=0.1, calibrate_on=HELD_OUT)
    loose.calibrate(residuals, 0.001)
    tight.calibrate(residuals, 0.001)
    assert loose.thresholds is not None and tight.thresholds is not None
    assert tight.thresholds[0] > loose.thresholds[0] > 4.0  # over 4 σ of the residual


def test_outside_the_calibrated_envelope_nothing_fires() -> None:
    rng = np.random.default_rng(4)
    residuals = rng.normal(size=(200, 100, 1))
    inputs = rng.uniform(-1.0, 1.0, size=(200, 100, 3))  # q, q', q'' within [-1, 1]
    detector = ContactDetector(1, envelope_margin=0.1, envelope_acceleration=True,
                               calibrate_on=HELD_OUT)
    detector.calibrate(residuals, 0.001, inputs=inputs)
    assert detector.armed
    big = np.array([100.0])
    assert detector.check(big, np.array([0.0, 0.5, -1.1])).tolist() == [True]  # in margin
    assert detector.check(big, np.array([0.0, 0.5, 5.0])).tolist() == [False]  # q'' out
    assert detector.check(big, np.array([-3.0, 0.0, 0.0])).tolist() == [False]  # q out
    assert detector.check(big, np.array([0.0, 1.3, 0.0])).tolist() == [False]  # q' out
    assert detector.held == 3
    assert detector.check(big).tolist() == [True]  # no input given: checked
    # by default q'' is not bounded (a contact is an acceleration), q and q' are
    default = ContactDetector(1, envelope_margin=0.1, calibrate_on=HELD_OUT)
    default.calibrate(residuals, 0.001, inputs=inputs)
    assert default.check(big, np.array([0.0, 0.5, 5.0])).tolist() == [True]
    assert default.check(big, np.array([0.0, 1.3, 0.0])).tolist() == [False]
    assert default.held == 1


def test_the_default_envelope_widens_the_a_priori_range_by_half() -> None:
    """A-priori, the envelope is the window's q, q' range (with the held-out segments'),
    widened by ``contact_envelope_margin``, by default half of it: a sample 0.4 of the range
    past it is checked, one 0.6 past it held (a quarter held whole pulses on unseen motion
    of the excitation loop, ``benchmarks/contact.md``)."""
    rng = np.random.default_rng(8)
    detector = ContactDetector(1)
    detector.observe(rng.normal(size=(4 * RECENT_CHUNK, 1)),
                     rng.uniform(-1.0, 1.0, size=(4 * RECENT_CHUNK, 3)))
    held_out = rng.uniform(0.0, 2.0, size=(10, 100, 3))  # widens the range to [-1, 2]
    detector.calibrate(None, 0.001, inputs=held_out)
    assert detector.armed
    big = np.array([100.0])
    assert detector.check(big, np.array([-2.1, 0.0, 0.0])).tolist() == [True]  # 0.37 past
    assert detector.check(big, np.array([0.0, 3.4, 0.0])).tolist() == [True]
    assert detector.check(big, np.array([-2.8, 0.0, 0.0])).tolist() == [False]  # 0.6 past
    assert detector.check(big, np.array([0.0, 3.8, 0.0])).tolist() == [False]
    assert detector.held == 2


def test_min_samples_needs_a_run_over_the_threshold() -> None:
    detector = ContactDetector(1, arm_nmse=1.0, min_samples=3, calibrate_on=HELD_OUT)
    detector.calibrate(np.random.default_rng(5).normal(size=(200, 100, 1)), 0.001)
    assert detector.armed
    over, under = np.array([50.0]), np.array([0.0])
    flags = [bool(detector.check(x)[0]) for x in (over, over, under, over, over, over, over)]
    assert flags == [False, False, False, False, False, True, True]


def test_a_priori_thresholds_bound_alarms_on_new_motion_where_held_out_ones_do_not() -> None:
    """The shift of ``benchmarks/contact.md``: a model errs less on held-out blocks (between
    learnt motion) than on new motion. Held-out residuals of scale 1, a-priori residuals
    (each sample predicted before it is learnt) and new motion of scale 2: thresholds from
    the a-priori ones keep the bound on 400 s of new motion, the held-out ones do not."""
    rng = np.random.default_rng(6)
    bound = 100.0  # per hour: 11 alarms allowed in 400 s, so the check can fail
    held_out = ar1_segments(rng, 200, 100, 0.8, (1.0, 0.1))
    a_priori = ar1_segments(rng, 1, 30_000, 0.8, (2.0, 0.2))[0]  # the last 30 s
    fresh = ar1_segments(rng, 4000, 100, 0.8, (2.0, 0.2))  # 400 s of new motion
    allowed = bound * 4000 * 0.1 / 3600.0

    def alarms(detector: ContactDetector) -> int:
        c = detector.calibration
        assert detector.armed, c.why_not
        assert c.false_alarms_per_hour is not None and c.false_alarms_per_hour <= bound
        return int((np.abs(fresh - c.centre) > c.thresholds).any(axis=(1, 2)).sum())

    before = ContactDetector(2, false_alarms_per_hour=bound, calibrate_on=HELD_OUT)
    before.calibrate(held_out, 0.001)
    after = ContactDetector(2, false_alarms_per_hour=bound)  # a-priori: the default
    after.observe(a_priori)
    after.calibrate(held_out, 0.001)
    assert alarms(before) > allowed
    assert alarms(after) <= allowed


def test_a_priori_draws_arm_from_the_residuals_checked() -> None:
    """Every residual :meth:`check` sees is kept; the window's independent draws (runs of
    at least twice the correlation time) arm it; a reset forgets them; only the last
    ``recent_s`` count; a detector of new settings takes them over."""
    rng = np.random.default_rng(7)
    detector = ContactDetector(2, recent_s=20.0)
    for row in rng.normal(size=(2 * RECENT_CHUNK - 1, 2)):
        detector.check(row)
    detector.calibrate(None, 0.001)
    assert not detector.armed and 'a-priori residuals' in detector.calibration.why_not
    detector.check(rng.normal(size=2))
    detector.calibrate(None, 0.001)  # 2,000 white samples: 20 draws of 100
    assert detector.armed and detector.calibration.independent == 20
    detector.reset()  # a new model: its residuals are to come
    detector.calibrate(None, 0.001)
    assert not detector.armed and 'a-priori residuals' in detector.calibration.why_not
    # joint 1 correlated past a run of 1,000: one draw per 2,000 samples
    slow = ar1_segments(rng, 1, 8 * 2 * RECENT_CHUNK, 0.9999, (1.0, 1.0))[0]
    slow[:, 0] = rng.normal(size=len(slow))
    detector.observe(slow[:7 * 2 * RECENT_CHUNK])
    detector.calibrate(None, 0.001)
    assert not detector.armed and detector.calibration.independent == 7 < MIN_DRAWS
    assert 'draws' in detector.calibration.why_not
    detector.observe(slow[7 * 2 * RECENT_CHUNK:])
    detector.calibrate(None, 0.001)
    assert detector.armed and detector.calibration.independent == MIN_DRAWS
    # a spike older than the window (20 s at 1 kHz) does not count
    detector.observe(np.array([1e3, 0.0]))
    detector.observe(rng.normal(size=(20_000, 2)))
    detector.calibrate(None, 0.001, sample_period_s=1e-3)
    assert detector.thresholds is not None and detector.thresholds[0] < 10.0
    kept = ContactDetector(2, recent_s=20.0, false_alarms_per_hour=0.5)
    kept.keep_recent(detector)
    kept.calibrate(None, 0.001)
    assert kept.armed and kept.thresholds is not None
    assert np.all(kept.thresholds >= detector.thresholds)  # the same draws, a tighter bound


def test_bad_settings_are_refused() -> None:
    for kwargs in ({'sigma': 0.0}, {'arm_nmse': -1.0}, {'min_samples': 0},
                   {'false_alarms_per_hour': 0.0}, {'envelope_margin': -0.1},
                   {'calibrate_on': 'validation'}, {'recent_s': 0.0}):
        with pytest.raises(ValueError):
            ContactDetector(2, **kwargs)


def test_held_out_segments_are_contiguous_samples_of_one_block() -> None:
    holdout = Holdout(1, 1, fraction=0.5, block=250, segment=100, segments=1000, seed=0)
    for index in range(20_000):
        if holdout.held_out(index):
            holdout.add(np.array([float(index)]), np.array([0.0]))
    segments = holdout.segments
    assert segments is not None and len(segments) > 50
    X = segments.X[:, :, 0]
    np.testing.assert_array_equal(X[:, 0] // 250, segments.blocks)
    np.testing.assert_array_equal(np.diff(X, axis=1), 1.0)  # consecutive samples
    assert np.all(X[:, 0] // 250 == X[:, -1] // 250)  # within one block


def test_held_out_residuals_are_measured_minus_predicted_of_the_held_out_samples() -> None:
    """The identifier hands out the current model's residuals on its held-out reservoir,
    and each prediction carries the sample's measured effort."""
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    record = Simulator(params, make_trajectory('standard', params, 0),
                       SimConfig()).simulate(1500)

    class Constant:
        n_inputs, n_outputs = 12, 4

        def predict(self, X: np.ndarray) -> np.ndarray:
            return np.ones(X.shape[:-1] + (4,))

        def partial_fit(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
            return np.asarray(Y - 1.0)

    ident = OnlineIdentifier(Constant(), joint_names=params.joint_names,
                             holdout=Holdout(12, 4, fraction=0.5, block=100, seed=0))
    results = []
    for i in range(len(record)):
        results += ident.process(int(record.stamp_ns[i]), params.joint_names, record.q[i],
                                 record.qd[i], record.effort[i])
    predicted = [r for r in results if r.effort is not None]
    assert predicted and all(r.measured is not None for r in predicted)
    by_stamp = {int(s): e for s, e in zip(record.stamp_ns, record.effort)}
    first = predicted[0]
    assert first.measured is not None
    np.testing.assert_array_equal(first.measured, by_stamp[first.stamp_ns])
    residuals = ident.held_out_residuals()
    assert residuals is not None and ident.holdout is not None
    assert len(residuals) == ident.counts.held_out > 100
    np.testing.assert_allclose(residuals, ident.holdout.reservoir.Y - 1.0)


class TrueModel:
    """The simulated SCARA's own inverse dynamics as the identified model (perfect)."""

    n_inputs, n_outputs = 12, 4

    def __init__(self, params: ScaraParams) -> None:
        self.model = ScaraModel(params)

    def predict(self, X: np.ndarray) -> np.ndarray:
        return np.asarray(self.model.inverse_dynamics(X[..., :4], X[..., 4:8], X[..., 8:]))

    def partial_fit(self, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return np.asarray(Y - self.predict(X))


def test_an_identified_model_detects_a_pulse_and_nothing_on_clean_unseen_motion() -> None:
    """The whole chain on the simulator's noisy stream: thresholds from an identifying
    model's held-out residuals; on motion of other seeds no contact without external
    effort, and a 10 % pulse applied to the dynamics found on its joint within 20 ms."""
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    model = TrueModel(params)
    ident = OnlineIdentifier(model, joint_names=params.joint_names, learn=False,
                             holdout=Holdout(12, 4, fraction=0.5, block=200, seed=0,
                                             segment=50))
    record, _ = pulse_record(params, seconds=16.0, seed=0, config=noisy_config(params, 0))
    for i in range(len(record)):
        ident.process(int(record.stamp_ns[i]), params.joint_names, record.q[i], record.qd[i],
                      record.effort[i])
    stats = ident.validation_stats()
    assert stats is not None and stats.nmse_total < 0.01  # it identifies
    segments = ident.holdout.segments if ident.holdout is not None else None
    assert segments is not None
    residuals = segments.Y - model.predict(segments.X.reshape(-1, 12)).reshape(
        segments.Y.shape)
    detector = ContactDetector(4, arm_nmse=0.01, calibrate_on=HELD_OUT)
    calibration = detector.calibrate(residuals, stats.nmse_total, inputs=segments.X)
    assert detector.armed, calibration.why_not

    clean, _ = pulse_record(params, seconds=10.0, seed=1, config=noisy_config(params, 1))
    _, external, _ = residuals_of(model, clean, params.joint_names)
    assert not detect(detector, external, _inputs(clean, params.joint_names)).any()

    pulsed, pulses = pulse_record(params, seconds=8.0, seed=2, config=noisy_config(params, 2),
                                  amplitude=0.1, pulse_s=0.1, spacing_s=1.0)
    index, external, _ = residuals_of(model, pulsed, params.joint_names)
    run = evaluate(np.zeros((1, 4), bool),
                   detect(detector, external, _inputs(pulsed, params.joint_names)), index,
                   pulses, dt=1e-3, clean_s=10.0)
    assert run.pulses >= 3 and run.detected == run.pulses
    assert {pulse.joint for pulse in pulses} == {0, 1, 2, 3}
    assert np.all(run.delays_s < 0.1)  # within the pulse


def _inputs(record: object, names: tuple[str, ...]) -> np.ndarray:
    stage = InputStage(JointMap(names, n_joints=4))
    _, X, _ = stage.batch(record.stamp_ns, names, record.q, record.qd,  # type: ignore
                          record.effort)  # type: ignore
    return np.asarray(X)
