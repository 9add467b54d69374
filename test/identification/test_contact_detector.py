"""Contact detection: thresholds from held-out residuals, arming, the check."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraModel, ScaraParams
from scara_ident_ros.paper.contact import detect, evaluate, pulse_record, residuals_of
from scara_ident_ros.paper.learning_curves import noisy_config
from scara_ident_ros.identification import Holdout, OnlineIdentifier
from scara_ident_ros.identification.contact_detector import (MAD_TO_SIGMA, ContactDetector,
                                                             robust_spread)
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory


def test_robust_spread_is_a_gaussians_std_and_ignores_outliers() -> None:
    rng = np.random.default_rng(0)
    residuals = rng.normal(0.0, [1.0, 0.1], size=(20_000, 2))
    residuals[:200] = 1e3  # 1 % gross errors barely move the median absolute deviation
    np.testing.assert_allclose(robust_spread(residuals), [1.0, 0.1], rtol=0.05)


def test_thresholds_are_sigma_times_the_mad_of_the_residuals() -> None:
    residuals = np.array([[-2.0, 10.0], [-1.0, 10.0], [0.0, 11.0], [1.0, 13.0],
                          [2.0, 14.0]] * 40)
    detector = ContactDetector(2, sigma=5.0, arm_nmse=0.1)
    detector.calibrate(residuals, 0.01)
    # joint 1: median 0, |deviations| 2 1 0 1 2, MAD 1; joint 2: median 11, MAD 1
    assert detector.thresholds is not None
    np.testing.assert_allclose(detector.thresholds, [5.0 * MAD_TO_SIGMA, 5.0 * MAD_TO_SIGMA])


def test_not_armed_before_the_model_identifies() -> None:
    detector = ContactDetector(2, sigma=3.0, arm_nmse=0.01)
    residuals = np.random.default_rng(1).normal(size=(500, 2))
    big = np.array([100.0, 100.0])
    assert not detector.check(big).any()  # no thresholds yet
    detector.calibrate(residuals, 0.5)  # NMSE above arm_nmse: not identified
    assert detector.thresholds is not None and not detector.armed
    assert not detector.check(big).any()
    detector.calibrate(residuals[:50], 0.001)  # too few held-out samples
    assert not detector.armed
    detector.calibrate(residuals, None)  # no validation score
    assert not detector.armed
    detector.calibrate(residuals, 0.001)
    assert detector.armed
    assert detector.check(np.array([100.0, 0.1])).tolist() == [True, False]
    assert detector.check(np.array([-100.0, np.nan])).tolist() == [True, False]


def test_min_samples_needs_a_run_over_the_threshold() -> None:
    detector = ContactDetector(1, sigma=3.0, arm_nmse=1.0, min_samples=3)
    detector.calibrate(np.random.default_rng(2).normal(size=(500, 1)), 0.001)
    over, under = np.array([50.0]), np.array([0.0])
    flags = [bool(detector.check(x)[0]) for x in (over, over, under, over, over, over, over)]
    assert flags == [False, False, False, False, False, True, True]


def test_bad_settings_are_refused() -> None:
    for kwargs in ({'sigma': 0.0}, {'arm_nmse': -1.0}, {'min_samples': 0}):
        with pytest.raises(ValueError):
            ContactDetector(2, **kwargs)


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
                             holdout=Holdout(12, 4, fraction=0.5, block=200, seed=0))
    record, _ = pulse_record(params, seconds=4.0, seed=0, config=noisy_config(params, 0))
    for i in range(len(record)):
        ident.process(int(record.stamp_ns[i]), params.joint_names, record.q[i], record.qd[i],
                      record.effort[i])
    stats = ident.validation_stats()
    assert stats is not None and stats.nmse_total < 0.01  # it identifies
    detector = ContactDetector(4, sigma=8.0, arm_nmse=0.01)
    detector.calibrate(ident.held_out_residuals(), stats.nmse_total)
    assert detector.armed

    clean, _ = pulse_record(params, seconds=10.0, seed=1, config=noisy_config(params, 1))
    _, external, _ = residuals_of(model, clean, params.joint_names)
    assert not detect(detector, external).any()

    pulsed, pulses = pulse_record(params, seconds=6.0, seed=2, config=noisy_config(params, 2),
                                  amplitude=0.1, pulse_s=0.1, spacing_s=1.0)
    index, external, _ = residuals_of(model, pulsed, params.joint_names)
    run = evaluate(np.zeros((1, 4), bool), detect(detector, external), index, pulses,
                   dt=1e-3, clean_s=10.0)
    assert run.pulses >= 3 and run.detected == run.pulses
    assert np.all(run.delays_s <= 0.02)
