"""The physically consistent fit: feasible bodies, and held-out torques close to least squares."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.consistent_parameters import (MIN_EIGENVALUE, consistency_report,
                                                            pseudo_inertia)
from scara_ident_ros.dynamics.physical_model import PhysicalModel

from physical_robots import SCARA_URDF, example_urdf, rnea, states  # test/physical_robots.py

UR5_URDF = example_urdf('ur_description/urdf/ur5_robot.urdf')


def test_the_pseudo_inertia_of_a_real_body_is_positive_and_a_flat_one_is_not() -> None:
    # a solid box 0.2 × 0.4 × 0.6 m of 3 kg, its centre at (0.1, 0, 0) from the joint frame
    m, c, size = 3.0, np.array([0.1, 0.0, 0.0]), np.array([0.2, 0.4, 0.6])
    central = m / 12.0 * np.diag([size[1] ** 2 + size[2] ** 2, size[0] ** 2 + size[2] ** 2,
                                  size[0] ** 2 + size[1] ** 2])
    about = central + m * (c @ c * np.eye(3) - np.outer(c, c))
    params = [m, *(m * c), about[0, 0], about[0, 1], about[1, 1], about[0, 2], about[1, 2],
              about[2, 2]]
    j = pseudo_inertia(params)
    np.testing.assert_allclose(j[:3, :3], m * (np.diag(size ** 2) / 12.0 + np.outer(c, c)))
    report = consistency_report(params)
    assert report['mass'] == 3.0 and report['pseudo_inertia'] > 0.0
    assert report['triangle'] > 0.0
    bad = list(params)
    bad[9] = params[4] + params[6] + 0.1  # I_zz > I_xx + I_yy: no body has it
    assert consistency_report(bad)['pseudo_inertia'] < 0.0


def noisy_data(urdf: Path, model: PhysicalModel, count: int,
               seed: int) -> tuple[np.ndarray, np.ndarray]:
    """X (count, 3n) and efforts of the URDF's bodies with friction and effort noise."""
    rng = np.random.default_rng(seed)
    n = model.n_joints
    q, qd, qdd = states(rng, count, n)
    tau = (rnea(urdf, None, q, qd, qdd) + 0.8 * qd + 1.5 * np.tanh(qd / 0.05)
           + rng.normal(0.0, 2.0, (count, n)))  # noise a few % of the efforts
    return np.hstack([q, qd, qdd]), tau


@pytest.mark.parametrize('urdf', [SCARA_URDF, UR5_URDF], ids=['scara', 'ur5'])
def test_the_consistent_fit_is_feasible_and_predicts_like_least_squares(urdf: Path) -> None:
    plain = PhysicalModel.from_urdf_file(urdf, coulomb_eps=0.05)
    consistent = PhysicalModel.from_urdf_file(urdf, coulomb_eps=0.05, consistent=True)
    x, tau = noisy_data(urdf, plain, 240, seed=3)
    held_x, held_tau = noisy_data(urdf, plain, 200, seed=4)
    plain.fit(x, tau)
    consistent.fit(x, tau)
    assert consistent.standard_theta is not None
    standard = consistent.standard_theta
    for body in range(consistent.n_bodies):
        report = consistency_report(standard[10 * body:10 * body + 10])
        assert report['mass'] > 0.0
        assert report['pseudo_inertia'] >= 0.99 * MIN_EIGENVALUE
        assert report['triangle'] >= -1e-7 and report['principal'] >= -1e-7
    assert np.all(standard[10 * consistent.n_bodies:] >= -1e-9)  # rotor inertias
    assert np.all(consistent.viscous >= -1e-9) and np.all(consistent.coulomb_friction >= -1e-9)
    # its θ are the base parameters of those standard parameters
    np.testing.assert_allclose(consistent.theta[:consistent.n_base],
                               consistent.reduction.base_values(standard), atol=1e-9)
    nmse = [np.mean((m.predict(held_x) - held_tau) ** 2, axis=0) / held_tau.var(axis=0)
            for m in (plain, consistent)]
    # the consistent fit's held-out torques stay close to unconstrained least squares
    assert np.all(nmse[1] <= 1.2 * nmse[0] + 1e-3), nmse


def test_consistent_standard_parameters_of_a_least_squares_fit() -> None:
    model = PhysicalModel.from_urdf_file(SCARA_URDF)
    model.set_theta(model.urdf_parameters())
    standard = model.consistent_standard()
    np.testing.assert_allclose(model.reduction.base_values(standard),
                               model.theta[:model.n_base], rtol=1e-4, atol=1e-5)
    assert all(consistency_report(standard[10 * b:10 * b + 10])['pseudo_inertia'] > 0.0
               for b in range(model.n_bodies))
