"""The physical and hybrid models learnt online by an identifier core, on the SCARA's URDF."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.hybrid_model import HybridModel
from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.dynamics.joint_limits import load_joint_limits
from scara_ident_ros.identification import CoreSettings, LazyCore, make_differentiator
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory

URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
NAMES = ['joint1', 'joint2', 'joint3', 'joint4']


def core_for(method: str, urdf: str) -> LazyCore:
    # the node's defaults, as config/identifier.yaml holds them (test/nodes checks it does)
    values = yaml.safe_load(config_path('identifier.yaml').read_text())['/**']['ros__parameters']
    values.update(method=method, validation_block=200)
    lazy = LazyCore(load_joint_limits(joint_names=NAMES), urdf=urdf, urdf_source=str(URDF))
    why = lazy.build(NAMES, CoreSettings.of(values), make_differentiator('centred'))
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
    assert core is not None and core.counts.learned > 4000
    validation = core.validation_stats()
    assert validation is not None
    # the SCARA is its URDF's rigid-body model with viscous and Coulomb friction: RLS
    # identifies it from seconds of motion (the networks need a minute)
    assert float(validation.nmse_total) < 1e-2, validation.nmse


def test_a_physical_model_without_a_urdf_says_what_it_needs() -> None:
    # the node's defaults, as config/identifier.yaml holds them (test/nodes checks it does)
    values = yaml.safe_load(config_path('identifier.yaml').read_text())['/**']['ros__parameters']
    values.update(method='physical')
    lazy = LazyCore(load_joint_limits(joint_names=NAMES))
    why = lazy.build(NAMES, CoreSettings.of(values), make_differentiator('centred'))
    assert 'needs the robot\'s URDF' in why and lazy.core is None
