"""Several methods of one session in any order: a learner or the physical model (no limit
scaling) named before a network whose limits the stream completes still builds them all."""
from __future__ import annotations

from pathlib import Path
import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.session import IdentificationSession
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory

SCARA = ScaraParams.from_yaml(config_path('scara.yaml'))
NAMES = list(SCARA.joint_names)
OTHER = ['axis_a', 'axis_b', 'axis_c', 'axis_d']
URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
MS = 1_000_000  # ns
T0 = 1_000 * 1_000_000_000  # ns


@pytest.mark.parametrize('methods', [['linear', 'ffs'], ['ffs', 'linear'],
                                     ['physical', 'linear', 'ffs']])
def test_every_method_predicts_whatever_the_order(methods: list[str], tmp_path: Path) -> None:
    # the SCARA's URDF under other joint names: no robot file knows their accelerations, so
    # the networks' scaling waits for the stream's first second
    text = URDF.read_text(encoding='utf-8')
    for name, other in zip(NAMES, OTHER):
        text = text.replace(f'"{name}"', f'"{other}"')
    urdf = tmp_path / 'renamed.urdf'
    urdf.write_text(text, encoding='utf-8')
    session = IdentificationSession(IdentifierSettings.defaults(
        lm_background=False, methods=methods, urdf_file=str(urdf), joint_names=OTHER))
    record = Simulator(SCARA, make_trajectory('standard', SCARA, seed=0),
                       SimConfig(seed=0)).simulate(2500)
    predicted = [0] * len(methods)
    for i in range(2500):
        outcome = session.process(T0 + i * MS, OTHER, record.q[i], record.qd[i],
                                  record.effort[i])
        for k, out in enumerate(outcome.predictions):
            predicted[k] += len(out)
    assert all(run.core is not None for run in session.runs)
    # every method predicts the same samples: all but the q'' estimate's last few
    assert len(set(predicted)) == 1 and predicted[0] > 2400, predicted
    assert [session.summary(run).method for run in session.runs] == methods
    assert np.isfinite(session.summary(session.runs[-1]).validation_nmse_total or 0.0)
