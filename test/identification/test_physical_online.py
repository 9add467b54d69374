"""The physical and hybrid models learnt online by an identifier core, on the SCARA's URDF."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.learners.hybrid_model import HybridModel, online_hybrid
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.dynamics.joint_limits import load_joint_limits
from scara_ident_ros.identification import IdentifierSettings, LazyCore, make_differentiator
from scara_ident_ros.identification.hybrid_trainer import HybridTrainer
from scara_ident_ros.identification.residual_learner import MIN_VALIDATION
from scara_ident_ros.identification.reservoir_lm import ReservoirLM
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory

URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
NAMES = ['joint1', 'joint2', 'joint3', 'joint4']


def core_for(method: str, urdf: str) -> LazyCore:
    # the node's defaults, as config/identifier.yaml holds them (test/nodes checks it does)
    settings = IdentifierSettings.from_yaml(config_path('identifier.yaml')).replace(
        method=method, validation_block=200)
    lazy = LazyCore(load_joint_limits(joint_names=NAMES), urdf=urdf, urdf_source=str(URDF))
    why = lazy.build(NAMES, settings, make_differentiator('centred'))
    assert why == ''
    return lazy


def stream(lazy: LazyCore, seconds: float) -> None:
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    record = Simulator(params, make_trajectory('sequence', params, seed=1),
                       SimConfig(seed=1)).simulate(round(seconds * 1000))
    core = lazy.core
    assert core is not None
    for k in range(len(record.q)):
        core.process(int(1e9 + k * 1e6), NAMES, record.q[k], record.qd[k], record.effort[k])


@pytest.mark.parametrize('method, kind', [('physical', PhysicalModel),
                                          ('hybrid', HybridModel)])
def test_a_physical_model_identifies_online(method: str, kind: type) -> None:
    lazy = core_for(method, URDF.read_text())
    assert isinstance(lazy.network, kind)
    stream(lazy, 6.0)
    core = lazy.core
    assert core is not None and core.counts.learnt > 4000
    validation = core.validation_stats()
    assert validation is not None
    # the SCARA is its URDF's rigid-body model with viscous and Coulomb friction: RLS
    # identifies it from seconds of motion (the networks need a minute)
    assert float(validation.nmse_total) < 1e-2, validation.nmse


def test_a_physical_model_without_a_urdf_says_what_it_needs() -> None:
    # the node's defaults, as config/identifier.yaml holds them (test/nodes checks it does)
    settings = IdentifierSettings.from_yaml(config_path('identifier.yaml')).replace(
        method='physical')
    lazy = LazyCore(load_joint_limits(joint_names=NAMES))
    why = lazy.build(NAMES, settings, make_differentiator('centred'))
    assert 'needs the robot\'s URDF' in why and lazy.core is None



def hybrid_after(samples: int) -> tuple[Any, Any, Any, np.ndarray, np.ndarray]:
    """A synchronous hybrid on the SCARA's URDF after ``samples`` samples (no update yet):
    the model, its trainer, the network's trainer, the inputs and efforts streamed."""
    limits = load_joint_limits(joint_names=NAMES).select(NAMES)
    model = online_hybrid(PhysicalModel.from_urdf_file(URDF), limits.scaling(), seed=0)
    network = ReservoirLM(model.network, reservoir_size=300, lm_interval=10_000)
    trainer = HybridTrainer(model, network, seed=0)
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    record = Simulator(params, make_trajectory('sequence', params, seed=2),
                       SimConfig(seed=2)).simulate(samples)
    X = np.hstack([record.q, record.qd, record.qdd])
    for k in range(len(X)):
        assert trainer.learn(X[k], record.effort[k]).shape == (4,)
    return model, trainer, network, X, record.effort


def test_the_hybrid_network_learns_the_residual_of_the_current_theta() -> None:
    """A synchronous ``lm`` network is fitted to τ − Y(x) θ with θ as it is at the update,
    not as it was when each sample arrived (hybrid_trainer's module docstring)."""
    model, trainer, network, X, effort = hybrid_after(1000)
    assert len(trainer.validation) >= MIN_VALIDATION
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    network.step_on = lambda x, y: seen.append((x, y)) and False  # type: ignore[method-assign]
    assert not trainer.step()
    (x, y), = seen
    assert x.shape == (300, 12)
    rows = {tuple(row): k for k, row in enumerate(X)}
    kept = [rows[tuple(row)] for row in x]  # which streamed samples the reservoir kept
    np.testing.assert_allclose(y, effort[kept] - model.physical.predict(X[kept]), atol=1e-9)
    validation = {rows[tuple(row)] for row in trainer.validation.X}
    assert not validation & set(kept)  # the network never learns a validation sample
    assert len(network.reservoir) == 0  # the network trainer's own reservoir is not used


def test_an_update_that_raises_the_validation_error_is_undone() -> None:
    model, trainer, network, X, _ = hybrid_after(1000)
    net = model.network
    before = net.get_theta()

    def spoil(x: np.ndarray, y: np.ndarray) -> bool:
        net.set_theta(before + np.random.default_rng(0).normal(0.0, 1.0, before.shape))
        return True

    network.step_on = spoil  # type: ignore[method-assign]
    assert not trainer.step() and trainer.undone == 1
    np.testing.assert_array_equal(net.get_theta(), before)
    network.step_on = ReservoirLM.step_on.__get__(network)  # type: ignore[method-assign]
    assert trainer.step()  # a real update on residuals lowers the validation error
    assert trainer.undone == 1 and not np.array_equal(net.get_theta(), before)


def test_the_online_gate_withholds_a_joint_the_network_makes_worse() -> None:
    model, trainer, network, X, _ = hybrid_after(1000)
    assert trainer.step()  # a real update
    net = model.network
    theta = net.get_theta()
    _, output = net.unpack(theta)
    output[0, -1] += 50.0  # joint 0's correction far off: worse than none on validation
    net.set_theta(theta)
    network.step_on = lambda x, y: False  # type: ignore[method-assign]
    assert not trainer.step()
    assert model.gate[0] == 0.0
    x = X[:50]
    np.testing.assert_array_equal(model.predict(x)[:, 0], model.physical.predict(x)[:, 0])
