"""Each parameter's %σ and the regressor's condition number, on a planar 2-link arm whose
regressor is written out by hand here."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.parameter_uncertainty import (UNDETERMINED_RELATIVE_STD,
                                                            condition_number,
                                                            parameter_uncertainty)
from scara_ident_ros.dynamics.physical_model import PhysicalModel

EPS = 0.05  # rad/s, the Coulomb tanh's
#: Two links turning about z (gravity along −z does not act), the elbow l1 = 1 m out: link
#: 2's mass then acts exactly as link 1's inertia and joint 1's rotor inertia do.
TWO_LINK_URDF = """<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/>
  <link name="upper">
    <inertial><origin xyz="0.5 0 0"/><mass value="3"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.3" iyz="0" izz="0.3"/></inertial>
  </link>
  <link name="fore">
    <inertial><origin xyz="0.3 0.1 0"/><mass value="2"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
  </link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-2.5" upper="2.5" velocity="3" effort="50"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2.5" upper="2.5" velocity="3" effort="20"/></joint>
</robot>
"""


@pytest.fixture(scope='module')
def arm() -> PhysicalModel:
    return PhysicalModel(TWO_LINK_URDF, coulomb='tanh', coulomb_eps=EPS)


def hand_built(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """The arm's base regressor (N·2, 9) from its equations of motion (l1 = 1 m), columns
    Izz1 (+ m2 l1² + Ia1), Izz2, m2 c_x, m2 c_y, Ia2, f_v1, f_v2, f_c1, f_c2."""
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    v1, v2 = qd.T
    a1, a2 = qdd.T
    zero = np.zeros_like(a1)
    coriolis = 2.0 * v1 * v2 + v2 ** 2
    columns = [
        (a1, zero), (a1 + a2, a1 + a2),
        ((2.0 * a1 + a2) * c2 - s2 * coriolis, c2 * a1 + s2 * v1 ** 2),
        (-(2.0 * a1 + a2) * s2 - c2 * coriolis, -s2 * a1 + c2 * v1 ** 2),
        (zero, a2), (v1, zero), (zero, v2),
        (np.tanh(v1 / EPS), zero), (zero, np.tanh(v2 / EPS))]
    return np.stack([np.stack(pair, axis=1) for pair in columns], axis=2).reshape(-1, 9)


def motion(count: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return (rng.uniform(-2.0, 2.0, (count, 2)), rng.normal(0.0, 1.5, (count, 2)),
            rng.normal(0.0, 4.0, (count, 2)))


def test_condition_number_is_the_hand_built_regressors(arm: PhysicalModel) -> None:
    assert arm.n_parameters == 9
    q, qd, qdd = motion(300, 0)
    expected = np.linalg.cond(hand_built(q, qd, qdd))
    assert condition_number(arm, q, qd, qdd) == pytest.approx(expected, rel=1e-8)
    # and the model's columns are those columns, in some order
    ours = arm.stacked_regressor(q, qd, qdd)
    theirs = hand_built(q, qd, qdd)
    matched = [int(np.argmin(np.linalg.norm(theirs - ours[:, [k]], axis=0)))
               for k in range(9)]
    assert sorted(matched) == list(range(9))
    np.testing.assert_allclose(ours, theirs[:, matched], atol=1e-9)


def test_relative_std_matches_the_spread_of_estimates_over_noise_seeds(
        arm: PhysicalModel) -> None:
    q, qd, qdd = motion(400, 1)
    truth = np.array([0.6, 0.3, 0.6, 0.2, 0.05, 0.4, 0.2, 0.8, 0.3])
    clean = arm.regressor(q, qd, qdd) @ truth
    noise = np.array([0.2, 0.05])  # N·m, a different level per joint
    w = hand_built(q, qd, qdd)
    rng = np.random.default_rng(2)
    estimates = []
    for _ in range(400):
        tau = clean + rng.normal(0.0, 1.0, clean.shape) * noise
        estimates.append(np.linalg.lstsq(w, tau.reshape(-1), rcond=None)[0])
    spread = np.std(estimates, axis=0, ddof=1)
    tau = clean + np.random.default_rng(3).normal(0.0, 1.0, clean.shape) * noise
    fitted = arm.fit_states(q, qd, qdd, tau)
    found = fitted.uncertainty
    assert found is not None and found.names == arm.parameter_names
    ours = hand_built(q, qd, qdd)  # the model's std in the hand-built columns' order
    order = [int(np.argmin(np.linalg.norm(ours - arm.stacked_regressor(q, qd, qdd)[:, [k]],
                                          axis=0))) for k in range(9)]
    np.testing.assert_allclose(found.std, spread[order], rtol=0.2)
    np.testing.assert_allclose(found.relative_std, found.std / np.abs(fitted.theta))
    assert found.undetermined_names == ()
    assert found.condition_number == pytest.approx(np.linalg.cond(w), rel=1e-8)


def test_a_joint_that_does_not_move_leaves_its_parameters_undetermined(
        arm: PhysicalModel) -> None:
    q, qd, qdd = motion(300, 4)
    q[:, 1], qd[:, 1], qdd[:, 1] = 0.7, 0.0, 0.0        # the elbow held still
    tau = arm.regressor(q, qd, qdd) @ np.full(9, 0.5)
    tau += np.random.default_rng(5).normal(0.0, 0.05, tau.shape)
    found = parameter_uncertainty(arm, q, qd, qdd, tau, np.full(9, 0.5))
    still = {'elbow.fv', 'elbow.fc', 'elbow.Ia'}
    assert still <= set(found.undetermined_names)
    for k, name in enumerate(found.names):
        if name in still:
            assert found.std[k] == np.inf and found.relative_std[k] == np.inf
    assert found.condition_number == np.inf
    assert UNDETERMINED_RELATIVE_STD == 0.10


def test_the_model_file_keeps_the_uncertainty(arm: PhysicalModel, tmp_path: Path) -> None:
    q, qd, qdd = motion(200, 6)
    tau = arm.regressor(q, qd, qdd) @ np.full(9, 0.5)
    tau += np.random.default_rng(7).normal(0.0, 0.1, tau.shape)
    model = PhysicalModel(TWO_LINK_URDF, coulomb='tanh', coulomb_eps=EPS)
    model.fit_states(q, qd, qdd, tau)
    model.save(tmp_path / 'arm.npz')
    loaded = PhysicalModel.load(tmp_path / 'arm.npz')
    assert model.uncertainty is not None and loaded.uncertainty is not None
    np.testing.assert_array_equal(loaded.uncertainty.std, model.uncertainty.std)
    assert loaded.uncertainty.condition_number == model.uncertainty.condition_number
    loaded.set_theta(loaded.theta)  # a new θ: the old σ no longer applies
    assert loaded.uncertainty is None


def test_mismatched_shapes_are_refused_and_an_exact_fit_has_no_sigma(arm: PhysicalModel) -> None:
    q, qd, qdd = motion(10, 8)
    with pytest.raises(ValueError, match='one shape'):
        parameter_uncertainty(arm, q, qd, qdd, q[:5], np.zeros(9))
    # 4 samples of 2 joints, 9 parameters: no residual left to tell the noise
    assert np.all(parameter_uncertainty(arm, q[:4], qd[:4], qdd[:4], q[:4],
                                        np.zeros(9)).std == np.inf)


def test_a_fit_weighted_by_joint_noise_is_the_weighted_least_squares_and_more_precise(
        arm: PhysicalModel) -> None:
    """Efforts of very different noise per joint: weighted by 1/each joint's residual RMS,
    the fit is the hand-built weighted least squares; its %σ matches the spread of weighted
    estimates over noise seeds, and is smaller than the unweighted fit's."""
    q, qd, qdd = motion(400, 4)
    truth = np.array([0.6, 0.3, 0.6, 0.2, 0.05, 0.4, 0.2, 0.8, 0.3])
    clean = arm.regressor(q, qd, qdd) @ truth
    noise = np.array([1.0, 0.01])  # N·m: a shoulder's sensor against a wrist's
    w = hand_built(q, qd, qdd)
    rng = np.random.default_rng(5)
    weighted_estimates = []
    for _ in range(300):
        tau = clean + rng.normal(0.0, 1.0, clean.shape) * noise
        weighted_estimates.append(np.linalg.lstsq(w / np.tile(noise, 400)[:, None],
                                                  (tau / noise).reshape(-1), rcond=None)[0])
    spread = np.std(weighted_estimates, axis=0, ddof=1)
    tau = clean + np.random.default_rng(6).normal(0.0, 1.0, clean.shape) * noise
    plain = PhysicalModel(TWO_LINK_URDF, coulomb='tanh', coulomb_eps=EPS,
                          reduction=arm.reduction).fit_states(q, qd, qdd, tau)
    weighted = PhysicalModel(TWO_LINK_URDF, coulomb='tanh', coulomb_eps=EPS, weighted=True,
                             reduction=arm.reduction).fit_states(q, qd, qdd, tau)
    # the weights are 1/the unweighted fit's residual RMS per joint
    sigma = plain.residual_rms
    expected = np.linalg.lstsq(arm.stacked_regressor(q, qd, qdd) / np.tile(sigma, 400)[:, None],
                               (tau / sigma).reshape(-1), rcond=None)[0]
    np.testing.assert_allclose(weighted.theta, expected, rtol=1e-8, atol=1e-10)
    # parameters that act on both joints are found far better (the shoulder's own friction
    # acts on its rows alone: no better)
    assert (np.median(np.abs(weighted.theta - truth))
            < 0.5 * np.median(np.abs(plain.theta - truth)))
    assert weighted.uncertainty is not None and plain.uncertainty is not None
    order = [int(np.argmin(np.linalg.norm(w - arm.stacked_regressor(q, qd, qdd)[:, [k]],
                                          axis=0))) for k in range(9)]
    np.testing.assert_allclose(weighted.uncertainty.std, spread[order], rtol=0.2)
    ratio = weighted.uncertainty.std / plain.uncertainty.std
    assert np.all(ratio < 1.01) and np.median(ratio) < 0.5
    # the residual RMS reported is of the efforts, not of the weighted rows
    np.testing.assert_allclose(
        weighted.residual_rms, np.sqrt(np.mean((weighted.predict(
            np.hstack([q, qd, qdd])) - tau) ** 2, axis=0)), rtol=1e-8)
