"""``method: linear`` in the identifier: the linear learner learnt online, in the caller's
process, ends at the batch solution of the samples it learnt (held-out ones never)."""
from __future__ import annotations

import numpy as np

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.estimator_learner import EstimatorLearner
from scara_ident_ros.identification.identifier_builder import build_identifier, make_model
from scara_ident_ros.learners import LinearFeatures
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory

SCARA = ScaraParams.from_yaml(config_path('scara.yaml'))
NAMES = list(SCARA.joint_names)
MS = 1_000_000  # ns
T0 = 1_000 * 1_000_000_000  # ns


def test_linear_learns_online_what_its_batch_fit_learns() -> None:
    record = Simulator(SCARA, make_trajectory('standard', SCARA, seed=0),
                       SimConfig(seed=0)).simulate(3000)
    settings = IdentifierSettings.defaults(method='linear', learner_batch=25,
                                           validation_fraction=0.2, validation_block=50)
    model = make_model(NAMES, settings, None)
    assert isinstance(model, LinearFeatures)
    identifier = build_identifier(NAMES, settings, model=model)
    results, inputs = [], []
    for i in range(3000):
        reason, given = identifier.stage.push(T0 + i * MS, tuple(NAMES), record.q[i],
                                              record.qd[i], record.effort[i])
        assert reason is None
        results += identifier.take(T0 + i * MS, reason, given)
        inputs += given
    trainer = identifier.trainer
    assert isinstance(trainer, EstimatorLearner)
    trainer.flush()
    assert trainer.stream.refits == 0  # past 2 x warm-up: a kernel learner is refitted there
    counts = identifier.counts
    assert counts.predicted == len(results) == len(inputs) > 2900 and counts.held_out > 0
    learner = identifier.model.learner  # type: ignore[union-attr]
    assert isinstance(learner, LinearFeatures)
    # the learner's batch solution on every learnt sample, never a held-out one: its
    # prediction of the held-out samples is better than of the mean, and equal to a batch
    # fit on the stream's other samples, which the test rebuilds from the inputs it saw
    learnt_x = np.array([i.x for r, i in zip(results, inputs) if not r.held_out])
    learnt_y = np.array([r.measured for r in results if not r.held_out])
    batch = LinearFeatures().fit(learnt_x, learnt_y)
    scale = np.abs(learnt_y).max()  # the features are near collinear on 1.5 s of motion:
    # compare what the models predict, not their coefficients
    np.testing.assert_allclose(learner.predict(learnt_x), batch.predict(learnt_x),
                               rtol=0.0, atol=1e-6 * scale)
    X_held = np.array([i.x for r, i in zip(results, inputs) if r.held_out])
    Y_held = np.array([r.measured for r in results if r.held_out])
    np.testing.assert_allclose(learner.predict(X_held), batch.predict(X_held), rtol=0.0,
                               atol=1e-6 * scale)
    assert learner.score(X_held, Y_held) > 0.5
