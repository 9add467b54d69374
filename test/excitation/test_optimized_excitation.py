"""The optimised excitation: it lowers the regressor's condition number from its seeded
start, predicts other motion with less variance than the random sequence of the same length,
keeps every limit, and the plan approaches it from rest and stops it to rest."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.dynamics.joint_limits import JointLimits
from scara_ident_ros.dynamics.parameter_uncertainty import condition_number
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.excitation import ExcitationPlan, make_chunk
from scara_ident_ros.excitation.optimized_excitation import (OptimizedExcitation,
                                                             optimize_excitation,
                                                             plan_condition)
from scara_ident_ros.sim.sequence import SEQUENCE_EXCITATION

sys.path.insert(0, str(Path(__file__).parent))  # --import-mode=importlib
from conftest import URDF  # noqa: E402
from smoothness import assert_consistent  # noqa: E402


@pytest.fixture(scope='module')
def model(margined: JointLimits) -> PhysicalModel:
    return PhysicalModel.from_urdf_file(URDF, joint_names=list(margined.names))


@pytest.fixture(scope='module')
def found(model: PhysicalModel, margined: JointLimits) -> OptimizedExcitation:
    return optimize_excitation(model, margined, seed=1, n_harmonics=8, period=8.0,
                               max_iterations=30)


def test_the_optimiser_lowers_the_condition_number_from_its_start(
        found: OptimizedExcitation, model: PhysicalModel) -> None:
    assert found.iterations >= 1
    assert found.condition < 0.7 * found.start_condition
    # the figure is cond(W) of the model's regressor over the period
    t = np.linspace(0.0, 8.0, 320, endpoint=False)
    assert condition_number(model, *found.trajectory.evaluate(t)) == pytest.approx(
        found.condition, rel=0.1)


def _prediction_variance(model: PhysicalModel, training: ExcitationPlan,
                         other: ExcitationPlan) -> float:
    """Σ_j tr(W_o,j (WᵀW)⁻¹ W_o,jᵀ) / var(τ_o,j): the criterion's variance term, computed
    along other motion than its reference (the held-out NMSE the noise gives, up to σ²/N)."""
    t = np.arange(0.0, 16.0, 0.02)
    w = model.regressor(*training.evaluate(training.approach_duration + t))
    w = w.reshape(-1, w.shape[-1])
    held = model.regressor(*other.evaluate(other.approach_duration + t))
    inverse = np.linalg.inv(w.T @ w)
    tau = held @ model.urdf_parameters()
    return float(np.sum(np.einsum('ijk,kl,ijl->j', held, inverse, held) / np.var(tau, axis=0)))


def test_the_optimised_motion_predicts_other_motion_better_than_the_random_sequence(
        found: OptimizedExcitation, margined: JointLimits, model: PhysicalModel) -> None:
    start = margined.centre
    optimised = ExcitationPlan(margined, start, seed=1, excitation=found)
    for seed in (1, 2):
        random = ExcitationPlan(margined, start, seed=seed)
        other = ExcitationPlan(margined, start, seed=50 + seed)
        assert (_prediction_variance(model, optimised, other)
                < 0.9 * _prediction_variance(model, random, other))


def test_the_optimised_motion_keeps_every_limit(found: OptimizedExcitation,
                                                margined: JointLimits) -> None:
    trajectory = found.trajectory
    assert trajectory.n_harmonics == 8 and trajectory.period == pytest.approx(8.0)
    np.testing.assert_allclose(trajectory.q0, margined.centre)
    t = np.arange(0.0, 8.0, 1e-3)
    q, qd, qdd = trajectory.evaluate(t)
    half = 0.5 * (margined.position_max - margined.position_min)
    fraction = SEQUENCE_EXCITATION['position_fraction']
    assert np.all(np.abs(q - margined.centre) <= fraction * half * (1 + 1e-4))
    assert np.all(np.abs(qd) <= SEQUENCE_EXCITATION['velocity_fraction']
                  * margined.velocity_max * (1 + 1e-4))
    assert np.all(np.abs(qdd) <= SEQUENCE_EXCITATION['acceleration_fraction']
                  * margined.acceleration_max * (1 + 1e-4))


def test_the_plan_approaches_it_from_rest_and_stops_at_rest(
        found: OptimizedExcitation, margined: JointLimits, model: PhysicalModel) -> None:
    start = np.array([-2.2, 2.4, 0.195, 6.0])        # in the margins, near the limits
    plan = ExcitationPlan(margined, start, seed=1, excitation=found)
    chunk = make_chunk(plan, 0.0, plan.approach_duration + 20.0, 0.001, margined)
    np.testing.assert_allclose(chunk.q[0], start, atol=1e-15)
    assert np.all(chunk.qd[0] == 0.0) and np.all(chunk.qd[-1] == 0.0)
    assert np.all(chunk.qdd[-1] == 0.0)
    assert margined.violations(chunk.q, chunk.qd, chunk.qdd, position_hull=start) == []
    assert_consistent(chunk.times, chunk.q, chunk.qd, chunk.qdd)
    # periodic after the approach
    t = plan.approach_duration + np.array([0.3, 2.1])
    for now, later in zip(plan.evaluate(t), plan.evaluate(t + 8.0)):
        np.testing.assert_allclose(now, later, atol=1e-9)
    random = ExcitationPlan(margined, start, seed=1)
    assert plan_condition(plan, model, 16.0, 0.02) < plan_condition(random, model, 16.0, 0.02)


def test_bad_settings_are_refused(model: PhysicalModel, margined: JointLimits) -> None:
    with pytest.raises(ValueError, match='n_harmonics'):
        optimize_excitation(model, margined, seed=0, n_harmonics=0)
    with pytest.raises(ValueError, match='period'):
        optimize_excitation(model, margined, seed=0, period=-1.0)


def test_the_gradient_is_the_criterions_central_difference(model: PhysicalModel,
                                                           margined: JointLimits) -> None:
    from scara_ident_ros.excitation.optimized_excitation import _Problem

    problem = _Problem(model, margined, 3, 6.0)
    x = problem.start(4)
    gradient = problem.gradient(x)
    for k in (0, 7, 13, x.size - 1):
        h = 1e-5 * max(1.0, abs(x[k]))
        step = np.zeros_like(x)
        step[k] = h
        central = (problem.objective(x + step) - problem.objective(x - step)) / (2 * h)
        assert gradient[k] == pytest.approx(central, rel=1e-3, abs=1e-6)


class _ElbowStop:
    """A stand-in collision check: the links 'meet' where joint 1 leaves ±``reach`` of the
    middle of its range."""

    def __init__(self, centre: np.ndarray, reach: float) -> None:
        self.centre, self.reach = centre, reach

    def colliding(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(np.abs(np.atleast_2d(q)[:, 1] - self.centre[1]) > self.reach)


def test_where_links_meet_only_that_joints_range_is_narrowed(
        model: PhysicalModel, margined: JointLimits) -> None:
    half = 0.5 * (margined.position_max - margined.position_min)
    stop = _ElbowStop(margined.centre, 0.3 * half[1])
    found = optimize_excitation(model, margined, seed=1, n_harmonics=4, period=8.0,
                                max_iterations=10, collision=stop)  # type: ignore[arg-type]
    assert found.narrowed is not None and found.narrowed[1] < 0.5
    np.testing.assert_array_equal(np.delete(found.narrowed, 1), 1.0)
    assert found.collision_scale == 1.0          # the narrowing sufficed: nothing shrunk
    q, qd, _ = found.trajectory.evaluate(np.arange(0.0, 8.0, 1e-3))
    assert not np.any(stop.colliding(q))
    fraction = SEQUENCE_EXCITATION['velocity_fraction']
    assert np.abs(qd[:, 0]).max() > 0.9 * fraction * margined.velocity_max[0]
