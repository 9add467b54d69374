"""The kernel learners as identifier methods (``kernel``, ``gp``): every sample predicted
before it is learnt, held-out samples never learnt, the learner what its own
``partial_fit`` makes, in the caller's process and in a learner process."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.estimator import load_model
from scara_ident_ros.identification.background_estimator import BackgroundEstimator
from scara_ident_ros.identification.estimator_learner import EstimatorLearner
from scara_ident_ros.identification.identifier_builder import build_identifier, make_model
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.learner_methods import LEARNER_WARMUP, make_learner_model
from scara_ident_ros.identification.session import IdentificationSession
from scara_ident_ros.identification.streamed_estimator import StreamedEstimator
from scara_ident_ros.learners import ExactGP, SparseSpectrumGP
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, SimRecord, Simulator, make_trajectory

SCARA = ScaraParams.from_yaml(config_path('scara.yaml'))
NAMES = list(SCARA.joint_names)
DEFAULTS = IdentifierSettings.from_yaml(config_path('identifier.yaml'))
MS = 1_000_000  # ns
T0 = 1_000 * 1_000_000_000  # ns


def simulated(n: int) -> SimRecord:
    simulator = Simulator(SCARA, make_trajectory('standard', SCARA, seed=0), SimConfig(seed=0))
    return simulator.simulate(n)


RECORD = simulated(2000)


def feed(session: IdentificationSession, n: int) -> tuple[list[Any], list[Any]]:
    """Process the first n samples; the first method's predictions and their inputs."""
    predictions: list[Any] = []
    inputs: list[Any] = []
    for i in range(n):
        outcome = session.process(
            T0 + i * MS, NAMES, RECORD.q[i], RECORD.qd[i], RECORD.effort[i])
        assert outcome.warnings == ()
        predictions += outcome.predictions[0]
        inputs += outcome.inputs
    assert len(predictions) == len(inputs)
    return predictions, inputs


def kernel_file(tmp_path: Path) -> Path:
    """A small fitted kernel model of the SCARA (cheap hyperparameters: from the scale)."""
    model = SparseSpectrumGP(40, hyperparameters='scale', seed=1)
    X = np.hstack([RECORD.q[:300], RECORD.qd[:300], RECORD.qdd[:300]])
    model.fit(X, RECORD.effort[:300])
    model.metadata['joint_names'] = np.array(NAMES)
    path = tmp_path / 'kernel.npz'
    model.save(path)
    return path


@pytest.mark.parametrize('batch', [1, 7])
def test_kernel_predicts_every_sample_and_learns_as_its_own_partial_fit(
        tmp_path: Path, batch: int) -> None:
    path = kernel_file(tmp_path)
    session = IdentificationSession(DEFAULTS.replace(
        method='kernel', model_path=str(path), lm_background=False, learner_batch=batch,
        validation_fraction=0.2, validation_block=50))
    predictions, inputs = feed(session, 1000)
    core = session.core
    assert core is not None
    counts = core.counts
    assert counts.predicted == len(predictions) == counts.processed - counts.pending
    assert sum(counts.skipped.values()) == 0
    assert counts.held_out > 0 and counts.learnt + counts.held_out == counts.predicted
    model = core.model
    assert isinstance(model, StreamedEstimator) and model.fitted
    trainer = core.trainer
    assert isinstance(trainer, EstimatorLearner) and trainer.sent == counts.learnt
    # the reference: the same file's learner, given the learnt samples in the same calls
    reference = load_model(path)
    assert isinstance(reference, SparseSpectrumGP)
    learnt = [(r, item) for r, item in zip(predictions, inputs) if not r.held_out]
    X = np.array([item.x for _, item in learnt])
    Y = np.array([item.effort for _, item in learnt])
    expected = np.empty_like(Y)
    for start in range(0, trainer.learnt, batch):
        stop = start + batch
        if batch == 1:
            expected[start:stop] = reference.partial_fit(X[start:stop], Y[start:stop])
        else:  # predicted by the learner as of the last full batch, then learnt
            expected[start:stop] = reference.predict(X[start:stop])
            reference.partial_fit(X[start:stop], Y[start:stop])
    done = trainer.learnt
    np.testing.assert_allclose([r.effort for r, _ in learnt[:done]], expected[:done],
                               rtol=1e-9, atol=1e-9)
    assert reference.n_samples_ == model.learner.n_samples_ == 300 + done  # type: ignore
    # held-out samples were never learnt: the learner took exactly the learnt ones
    assert counts.learnt - done < batch
    held = np.array([item.x for r, item in zip(predictions, inputs) if r.held_out])
    np.testing.assert_allclose(model.predict(held), reference.predict(held), rtol=1e-9,
                               atol=1e-9)


def test_gp_warms_up_on_the_running_mean_then_learns_what_partial_fit_learns() -> None:
    settings = IdentifierSettings.defaults(method='gp', gp_budget=2000, learner_batch=25,
                                           validation_fraction=0.2, validation_block=50)
    model = make_model(NAMES, settings, None)
    assert isinstance(model, ExactGP)
    identifier = build_identifier(NAMES, settings, model=model)
    stream = identifier.model
    assert isinstance(stream, StreamedEstimator) and not stream.fitted
    results = []
    for i in range(1500):
        for r in identifier.process(T0 + i * MS, NAMES, RECORD.q[i], RECORD.qd[i],
                                    RECORD.effort[i]):
            results.append(r)
    counts = identifier.counts
    assert counts.predicted == len(results) and counts.held_out > 0
    # the warm-up's predictions: the running mean of the efforts learnt before each
    warm = [r for r in results if not r.held_out][:LEARNER_WARMUP]
    efforts = np.array([r.measured for r in warm])
    means = np.vstack([np.zeros(len(NAMES)),
                       np.cumsum(efforts, axis=0)[:-1] / np.arange(1, len(warm))[:, None]])
    np.testing.assert_allclose([r.effort for r in warm[1:]], means[1:], rtol=1e-9, atol=1e-9)
    assert stream.fitted
    trainer = identifier.trainer
    assert isinstance(trainer, EstimatorLearner)
    # the learner saw exactly the learnt samples (held-out ones never): its own count
    assert stream.learner.n_seen_ == trainer.learnt  # type: ignore[attr-defined]
    assert trainer.sent == counts.learnt and counts.learnt - trainer.learnt < 25


def test_a_learner_process_learns_and_hands_its_state_back(tmp_path: Path) -> None:
    path = kernel_file(tmp_path)
    learner = load_model(path)
    stream = StreamedEstimator(learner, len(NAMES))  # type: ignore[arg-type]
    background = BackgroundEstimator(stream, batch=20, warmup=LEARNER_WARMUP)
    try:
        assert background.wait_ready(30.0)
        X = np.hstack([RECORD.q, RECORD.qd, RECORD.qdd])[300:800]
        Y = RECORD.effort[300:800]
        for x, y in zip(X, Y):
            background.learn(x, y)
    finally:
        background.close()
    assert background.sent == 500 and background.dropped == 0
    assert background.learnt == 500 and background.updates >= 1
    reference = load_model(path)
    reference.partial_fit(X, Y)  # type: ignore[attr-defined]
    # the caller's model is the process's final state: what partial_fit of the samples makes
    np.testing.assert_allclose(stream.predict(X[:50]), reference.predict(X[:50]),
                               rtol=1e-7, atol=1e-7)
    assert stream.learner.n_samples_ == 800  # type: ignore[attr-defined]


def test_the_saved_learner_warm_starts_an_identifier(tmp_path: Path) -> None:
    path = kernel_file(tmp_path)
    session = IdentificationSession(DEFAULTS.replace(
        method='kernel', model_path=str(path), lm_background=False, validation_fraction=0.0,
        save_path=str(tmp_path / 'out.npz')))
    feed(session, 200)
    ok, message = session.save()
    assert ok, message
    saved = load_model(tmp_path / 'out.npz')
    assert saved.kind == 'kernel' and saved.method == 'kernel'
    assert list(saved.joint_names or ()) == NAMES
    core = session.core
    assert core is not None
    X = np.hstack([RECORD.q[:20], RECORD.qd[:20], RECORD.qdd[:20]])
    np.testing.assert_allclose(saved.predict(X), core.model.predict(X), rtol=1e-9)


def test_an_unfitted_learner_is_not_saved(tmp_path: Path) -> None:
    session = IdentificationSession(DEFAULTS.replace(method='gp', lm_background=False,
                                                     save_path=str(tmp_path / 'gp.npz')))
    feed(session, 100)  # fewer than the warm-up
    ok, message = session.save()
    assert not ok and 'learnt nothing yet' in message
    assert not (tmp_path / 'gp.npz').exists()


def test_make_learner_model_refuses_other_methods() -> None:
    with pytest.raises(ValueError, match='not a learner method'):
        make_learner_model('ffs')


def test_a_fresh_learner_is_refitted_on_its_reservoir_as_the_stream_grows() -> None:
    settings = IdentifierSettings.defaults(method='kernel', kernel_features=40,
                                           learner_batch=10, learner_warmup=100,
                                           reservoir_size=250, validation_fraction=0.0)
    identifier = build_identifier(NAMES, settings)
    for i in range(1000):
        identifier.process(T0 + i * MS, NAMES, RECORD.q[i], RECORD.qd[i], RECORD.effort[i])
    trainer = identifier.trainer
    assert isinstance(trainer, EstimatorLearner)
    stream = trainer.stream
    learnt = stream.learnt
    assert learnt == trainer.learnt and learnt // 10 * 10 == learnt >= 960
    assert stream.refits == 3  # at 200, 400 and 800 samples
    learner = stream.learner
    assert isinstance(learner, SparseSpectrumGP)
    assert identifier.model.learner is learner  # type: ignore[attr-defined]
    # refitted at 800 on the reservoir's 250 samples, then the rest one call at a time
    assert learner.n_samples_ == 250 + learnt - 800
