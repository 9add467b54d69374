"""The identifier's session without ROS: warm starts, methods on one input stage, reset,
parameters changed while running, lags and the summary."""
from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from scara_ident_ros.dynamics import ScaraModel, ScaraParams
from scara_ident_ros.dynamics.joint_limits import LimitsError
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.reports import SkipCounts, StreamFigures
from scara_ident_ros.identification.session import IdentificationSession
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.reservoir_lm import ReservoirLM
from scara_ident_ros.identification.warm_start import ModelMismatch
from scara_ident_ros.nn.presets import limit_scaling, make_network
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, SimRecord, Simulator, make_trajectory

SCARA = ScaraParams.from_yaml(config_path('scara.yaml'))
SCARA_MODEL = ScaraModel(SCARA)
NAMES = list(SCARA.joint_names)
DEFAULTS = IdentifierSettings.from_yaml(config_path('identifier.yaml'))
MS = 1_000_000  # ns
T0 = 1_000 * 1_000_000_000  # ns
LAG = DEFAULTS.window // 2  # samples the centred q'' estimate holds back
URDF = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
WAIT = 30.0  # s: the longest a test waits for a learner process (a loaded CI machine)


def settings(**changes: Any) -> IdentifierSettings:
    """The node's defaults with ``changes``; learning in the message path (no process)."""
    return DEFAULTS.replace(**{'lm_background': False, **changes})


def simulated(n: int) -> SimRecord:
    simulator = Simulator(SCARA, make_trajectory('standard', SCARA, seed=0), SimConfig(seed=0))
    return simulator.simulate(n)


def feed(session: IdentificationSession, record: SimRecord, n: int,
         start: int = 0) -> list[list[Any]]:
    """Process samples start..n-1; return each method's predictions."""
    out: list[list[Any]] = [[] for _ in session.runs]
    for i in range(start, n):
        outcome = session.process(T0 + i * MS, NAMES, record.q[i], record.qd[i],
                                  record.effort[i])
        assert outcome.warnings == ()
        for mine, theirs in zip(out, outcome.predictions):
            mine.extend(theirs)
    return out


def saved_model(path: Path, names: list[str]) -> Path:
    network = make_network('ffs', len(names))
    index = [NAMES.index(name) for name in names]
    network.set_scaling(*limit_scaling(*(SCARA.array(key)[index] for key in (
        'position_min', 'position_max', 'velocity_max', 'acceleration_max', 'effort_max'))))
    network.metadata['joint_names'] = np.array(names)
    network.save(path)
    return path


def test_the_joints_come_from_the_first_valid_sample() -> None:
    session = IdentificationSession(settings(derive_velocity='never'))  # [] q': invalid
    assert session.core is None and session.joints_text == '(from the first message)'
    record = simulated(50)
    warnings = session.process(T0, NAMES[:2], record.q[0, :2], [], []).warnings
    assert warnings and 'before the first valid one' in warnings[-1]
    assert session.core is None and session.processed() == 1
    predictions, = feed(session, record, 50, start=1)
    assert session.names == NAMES and len(predictions) == 49 - LAG
    assert session.summary().skipped == SkipCounts({'no_velocity': 1})


def test_several_methods_share_one_input_stage() -> None:
    session = IdentificationSession(settings(methods=['ffmw', 'ffs'], joint_names=NAMES))
    ffmw, ffs = session.runs
    assert ffmw.core is not None and ffs.core is not None
    assert ffmw.core.stage is ffs.core.stage  # each sample checked and differentiated once
    a, b = feed(session, simulated(100), 100)
    assert [r.stamp_ns for r in a] == [r.stamp_ns for r in b] == [
        T0 + i * MS for i in range(100 - LAG)]
    assert not np.allclose([r.effort for r in a], [r.effort for r in b])  # two networks
    assert session.summary(ffs).method == 'ffs' and session.processed() == 100


def test_a_joint_set_mismatch_says_how_to_fix_it() -> None:
    session = IdentificationSession(settings(joint_names=NAMES))
    record = simulated(1)
    outcome = session.process(T0, NAMES[:3], record.q[0, :3], record.qd[0, :3],
                              record.effort[0, :3])
    assert outcome.predictions == ((),) and outcome.skipped is SkipReason.MISSING_JOINT
    warnings = outcome.warnings
    assert 'set joint_names, or min_joints' in warnings[0]


@pytest.mark.parametrize('changes, error, message', [
    ({'methods': ['ffs', 'ffs']}, ConfigError, 'names a method twice'),
    ({'methods': ['ffmw', 'ffs'], 'save_path': 'model.npz'}, ConfigError,
     'the path needs {method}'),
    ({'joint_names': ['a', 'b']}, ConfigError, 'joint_names: no joint limits for'),
    ({'joint_names': ['a'], 'effort_max': [1.0]}, LimitsError, 'must all be given'),
])
def test_bad_settings_are_one_line(changes: dict[str, Any], error: type[Exception],
                                   message: str) -> None:
    with pytest.raises(error, match=message):
        IdentificationSession(settings(**changes))


def test_a_model_at_save_path_is_continued(tmp_path: Path) -> None:
    path = saved_model(tmp_path / 'model.npz', NAMES)
    logged: list[str] = []
    session = IdentificationSession(settings(save_path=str(path)), log=logged.append)
    assert session.model_source('ffs') == str(path)
    assert any('continuing from the model at save_path' in line for line in logged)
    assert session.names == NAMES  # the model's joints: built at start
    assert isinstance(session.network, FeedForwardNet)
    np.testing.assert_array_equal(session.network.get_theta(),
                                  FeedForwardNet.load(path).get_theta())
    # model_path wins over save_path
    other = saved_model(tmp_path / 'other.npz', NAMES)
    both = IdentificationSession(settings(save_path=str(path), model_path=str(other)))
    assert both.model_source('ffs') == str(other)


def test_a_warm_start_for_another_joint_order_is_refused(tmp_path: Path) -> None:
    path = saved_model(tmp_path / 'model.npz', NAMES)
    with pytest.raises(ModelMismatch, match='in that order'):
        IdentificationSession(settings(model_path=str(path), joint_names=NAMES[::-1]))
    with pytest.raises(ConfigError, match='cannot warm-start'):
        IdentificationSession(settings(model_path=str(tmp_path / 'none.npz')))


def test_reset_keeps_the_summaries_of_before(tmp_path: Path) -> None:
    session = IdentificationSession(settings(trainer='bp'))
    assert session.reset() == (False, 'nothing to reset: no model yet (no valid sample so '
                                      'far)', '')
    record = simulated(300)
    feed(session, record, 200)
    trained = session.network
    assert trained is not None
    weights = trained.get_theta()
    ok, message, warning = session.reset(stream=StreamFigures(lost=3))
    assert ok and warning == '' and 'ffs: processed 200, learnt' in message
    assert session.network is not None
    assert not np.array_equal(session.network.get_theta(), weights)  # fresh weights
    feed(session, record, 300, start=200)
    info = session.summary().as_dict()  # as the stats_file holds it
    previous, = info['previous']
    assert previous['processed'] == 200 and previous['predicted'] == 200 - LAG
    assert previous['lost'] == 3 and 'previous' not in previous
    assert info['processed'] == 100 and info['predicted'] == 100 - LAG


def test_parameters_set_while_running_reach_core_and_trainer() -> None:
    s = settings(joint_names=NAMES)
    session = IdentificationSession(s)
    core = session.core
    assert core is not None and isinstance(core.trainer, ReservoirLM)
    session.apply(s.replace(learn=False, lm_interval=400, lm_steps=1, mse_window=500))
    assert core.learn is False and core.stage.check.need_effort is False
    assert core.trainer.lm_interval == 400 and core.trainer.lm_steps == 1
    assert core.errors.window == 500
    bp = settings(joint_names=NAMES, trainer='bp')
    session = IdentificationSession(bp)
    network = session.network
    assert isinstance(network, FeedForwardNet)
    session.apply(bp.replace(learning_rate=0.125, momentum=0.25))
    assert (network.learning_rate, network.momentum) == (0.125, 0.25)
    session.apply(session.settings.replace(contact_sigma=3.0))
    assert session.first.detector is not None and session.first.detector.sigma == 3.0
    assert session.settings.learning_rate == 0.125  # the settings of before, but one


def test_lags_are_kept_per_method_and_reported_once_per_period() -> None:
    session = IdentificationSession(settings(joint_names=NAMES))
    run = session.first
    for lag_ms in (2, 9, 4):
        run.record_lag(lag_ms * MS)
    assert (run.line_lag_ns, run.worst_lag_ns) == (9 * MS, 9 * MS)
    assert session.health_figures(run).period_worst_lag_ms == pytest.approx(9.0)
    # reported: the period starts anew
    assert session.health_figures(run).period_worst_lag_ms is None
    run.line_lag_ns = 0  # as a statistics line does
    run.record_lag(1 * MS)
    info = session.summary(stream=StreamFigures(lost=0))
    assert info.worst_lag_ms == 9.0 and info.stream is not None and info.stream.lost == 0
    assert info.lag_p99_ms is not None and info.lag_p50_ms is not None
    assert info.lag_p99_ms >= info.lag_p50_ms > 0


def test_save_says_why_not_and_writes_atomically(tmp_path: Path) -> None:
    session = IdentificationSession(settings())
    assert session.save() == (False, 'no save_path: start the node with -p '
                                     'save_path:=<file>.npz')
    path = tmp_path / 'models' / 'model.npz'
    session = IdentificationSession(settings(save_path=str(path)))
    ok, message = session.save()
    assert not ok and 'no model yet' in message
    feed(session, simulated(30), 30)
    ok, message = session.save()
    assert ok and str(path) in message and path.is_file()


def test_a_background_hybrid_reports_its_learners_updates() -> None:
    """method:=hybrid with the default learner process: the session's learning statistics
    are its network's learner's."""
    # lm_nice 0, the learner at the stream's priority: at the default niceness a loaded CI
    # machine can starve it for longer than the wait (the reporting is tested here)
    urdf = Path(__file__).resolve().parents[2] / 'urdf' / 'scara.urdf'
    session = IdentificationSession(settings(method='hybrid', lm_background=True, lm_nice=0,
                                             urdf_file=str(urdf), joint_names=NAMES))
    record = Simulator(SCARA, make_trajectory('sequence', SCARA, seed=1),
                       SimConfig(seed=1)).simulate(6000)
    try:
        run, = session.runs
        assert run.background is not None and run.background.hybrid is run.network
        assert run.background.wait_ready(WAIT)
        assert os.getpriority(os.PRIO_PROCESS, run.background._process.pid) == \
            os.getpriority(os.PRIO_PROCESS, 0)  # lm_nice reached the learner
        # a stream, not a burst: the learner updates once per 200 new samples, and an
        # update its validation check undoes is no update
        deadline = time.monotonic() + WAIT
        for i in range(6000):
            session.process(T0 + i * MS, NAMES, record.q[i], record.qd[i], record.effort[i])
            if i % 250 == 249:
                time.sleep(0.05)
                run.background.poll()
                if (i > 3000 and run.background.updates >= 1) or time.monotonic() > deadline:
                    break
        while run.background.updates == 0 and time.monotonic() < deadline:
            run.background.poll()
            time.sleep(0.05)
        assert run.background.updates >= 1
        learning = run.learning()
        assert learning is not None and learning.updates == run.background.updates
        assert session.summary(run).as_dict()['updates'] == learning.updates
    finally:
        session.close()


@pytest.mark.parametrize('derive', ['auto', 'never'])
def test_a_stream_without_velocities_is_predicted_with_derived_velocities(derive: str) -> None:
    """Positions and efforts only (the TX40's kind): with derive_velocity auto every sample
    is predicted, q' from the positions close to the simulator's; never: all no_velocity."""
    record = simulated(400)
    session = IdentificationSession(settings(derive_velocity=derive, learn=False))
    inputs = []
    for i in range(400):
        inputs += session.process(T0 + i * MS, NAMES, record.q[i], [], record.effort[i]).inputs
    inputs += session.flush().inputs
    summary = session.summary()
    if derive == 'never':
        assert summary.skipped.as_dict() == {'no_velocity': 400} and not inputs
        return
    assert summary.processed == summary.predicted == 400 and summary.skipped.total == 0
    qd = np.array([item.x[4:8] for item in inputs])
    stamps = [(item.stamp_ns - T0) // MS for item in inputs]
    inner = slice(LAG, -LAG)  # centred fits (the history's ends are off-centre, noisier)
    np.testing.assert_allclose(qd[inner], record.qd[stamps][inner],
                               atol=1e-2 * np.abs(record.qd).max())


def noisy_session(n: int, length: int, noise: float = 0.05
                  ) -> tuple[IdentificationSession, SimRecord]:
    """A session fed the first ``n`` samples of a ``length``-sample record with sensor
    noise (σ a fraction ``noise`` of the effort limits), its contact detector (on the
    held-out segments) not calibrated yet, and the record."""
    record = simulated(length)
    rng = np.random.default_rng(0)
    record.effort[:] += rng.normal(size=record.effort.shape) * noise * SCARA.array(
        'effort_max')  # 40 held-out blocks: enough draws either way
    session = IdentificationSession(settings(  # 4,000 samples of a model still learning:
        joint_names=NAMES, validation_fraction=0.5, validation_block=50,  # few a-priori
        contact_arm_nmse=10.0, contact_calibration='held-out'))  # draws, many held-out
    feed(session, record, n)
    return session, record


def test_contact_calibration_is_an_explicit_step_and_arms_on_the_rate_bound() -> None:
    """Reading the validation score changes no threshold; the calibration step does, in
    budgeted steps, and arms detection once the held-out draws allow the bound."""
    session, _ = noisy_session(4000, 4000)
    run = session.first
    assert run.detector is not None
    run.validation(fresh=True)
    assert run.detector.thresholds is None and not run.detector.armed  # a getter
    steps = 0
    while run.calibrate_contacts(1e-3, budget=500) is None:
        steps += 1
        assert steps < 100
    assert steps > 3  # several steps: the round was cut into budgets
    calibration = run.detector.calibration
    assert run.detector.armed, calibration.why_not
    assert calibration.false_alarms_per_hour is not None
    assert calibration.false_alarms_per_hour <= 1.0 + 1e-9
    figures = session.health_figures(run).as_dict()
    assert figures['contact_armed'] and figures['contact_why_not'] == ''
    summary = session.summary(run)
    assert summary.contact_armed and summary.contact_thresholds is not None
    assert len(summary.contact_thresholds) == 4
    # set (to its value): a new detector, not armed
    session.apply(session.settings, {'contact_false_alarms_per_hour'})
    assert not run.detector.armed
    assert run.calibrate_contacts(1e-3) is not None and run.detector.armed


RATE = 200.0  # Hz: a real arm's rate, few enough samples for a minute of stream


def sines(seconds: float, seed: int) -> tuple[np.ndarray, ...]:
    """A minute-scale SCARA stream at :data:`RATE`: stamps (ns), q, q' of three sines per
    joint within its limits, and the effort of the SCARA's inverse dynamics plus a model
    error the physical model cannot fit (an AR(1) of 0.2 s, 2 % of each joint's effort
    spread: it outlasts a held-out segment, so each held-out block is one draw)."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(seconds * RATE)) / RATE
    lo, hi = SCARA.array('position_min'), SCARA.array('position_max')
    w = 2.0 * np.pi * rng.uniform(0.05, 0.4, size=(3, 4))
    a = rng.uniform(0.05, 0.1, size=(3, 4)) * (hi - lo)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=(3, 4))
    arg = w * t[:, None, None] + phase
    q = 0.5 * (lo + hi) + (a * np.sin(arg)).sum(axis=1)
    qd = (a * w * np.cos(arg)).sum(axis=1)
    qdd = -(a * w * w * np.sin(arg)).sum(axis=1)
    rho = np.exp(-1.0 / (0.2 * RATE))
    error = np.empty_like(q)
    error[0] = rng.normal(size=4)
    for k in range(1, len(t)):
        error[k] = rho * error[k - 1] + np.sqrt(1.0 - rho * rho) * rng.normal(size=4)
    effort = np.asarray(SCARA_MODEL.inverse_dynamics(q, qd, qdd))
    return (T0 + np.round(t * 1e9).astype(np.int64), q, qd,
            effort + 0.02 * effort.std(axis=0) * error)


@pytest.mark.slow
def test_a_minute_of_stream_arms_contacts_with_no_false_one_and_a_push_is_found() -> None:
    """The node's defaults (10 % held out in 0.5 s blocks, a calibration every 10 s of
    stream): armed once 8 held-out blocks are in, within the first minute; then 30 s
    (6,000 samples) of quiet unseen motion without a contact, and a push of 10 % of joint
    2's effort limit found on joint 2 alone."""
    session = IdentificationSession(settings(method='physical', urdf_file=str(URDF),
                                             joint_names=NAMES))
    run = session.first
    stamps, q, qd, effort = sines(90.0, 0)
    minute, every = round(60 * RATE), round(10 * RATE)
    armed_at = None
    for i in range(minute):
        session.process(int(stamps[i]), NAMES, q[i], qd[i], effort[i])
        if (i + 1) % every == 0:
            run.calibrate_contacts(1.0 / RATE)
            assert run.detector is not None
            if run.detector.armed and armed_at is None:
                armed_at = (i + 1) / RATE
    assert run.detector is not None and run.detector.armed, run.detector.calibration.why_not
    assert armed_at is not None and armed_at <= 60.0
    assert run.detector.calibration.independent >= 8
    held, contacts = run.detector.held, run.contacts
    predictions = []
    push, pushed_from = np.zeros(4), int(stamps[-100])  # the last 0.5 s: pushed on joint 2
    for i in range(minute, len(stamps)):
        if stamps[i] == pushed_from:
            push[1] = 0.1 * SCARA.array('effort_max')[1]
        predictions += session.process(int(stamps[i]), NAMES, q[i], qd[i],
                                       effort[i] + push).predictions[0]
        if (i + 1) % every == 0:
            run.calibrate_contacts(1.0 / RATE)
    quiet = [p.contact for p in predictions if p.stamp_ns < pushed_from]
    pushed = [p.contact for p in predictions if p.stamp_ns >= pushed_from]
    assert len(quiet) > 5500 and not any(c is None or c.any() for c in quiet)
    assert run.detector.held - held < 0.1 * len(quiet)  # checked, not held off the envelope
    assert any(c is not None and c[1] for c in pushed)
    assert not any(c is not None and c[[0, 2, 3]].any() for c in pushed)
    assert run.contacts > contacts


def test_each_prediction_comes_with_its_external_torque_contact_flags_and_lag() -> None:
    """The session decides all the node publishes: external torque = measured − predicted,
    the armed detector's flags (a push on one joint only), and the lag, recorded per method.

    The thresholds follow the network 4,000 samples taught (joint 2's was 20 N·m with two
    BLAS threads, 79 with one): the push goes to the joint with the most room for it under
    its effort limit, which a push beyond would make a sample the session refuses."""
    session, record = noisy_session(4000, 4000, noise=0.01)
    run = session.first
    assert run.calibrate_contacts(1e-3) is not None and run.detector is not None
    assert run.detector.armed and run.detector.thresholds is not None
    # motion seen before (inside the calibrated envelope), after a pause of 1 s
    again, pushed_from = range(2000, 2300), T0 + 7150 * MS
    room = SCARA.array('effort_max') - np.abs(record.effort[again]).max(axis=0)  # N·m
    joint = int(np.argmax(room / run.detector.thresholds))
    push = np.zeros(4)
    push[joint] = 2.5 * run.detector.thresholds[joint]  # N·m, over that joint's threshold
    assert push[joint] < room[joint]
    lags_before = run.lags.count
    predictions = []
    for i in again:
        stamp = T0 + (5000 + i) * MS
        effort = record.effort[i] + (push if stamp >= pushed_from else 0.0)
        predictions += session.process(stamp, NAMES, record.q[i], record.qd[i],
                                       effort).predictions[0]
    assert predictions and run.lags.count - lags_before == len(predictions)
    for p in predictions:
        assert p.measured is not None and p.external is not None and p.contact is not None
        np.testing.assert_array_equal(p.external, p.measured - p.effort)
        assert p.lag_ns is not None and p.lag_ns >= 0
    pushed = [p.contact for p in predictions if p.stamp_ns >= pushed_from]
    quiet = [p.contact for p in predictions if p.stamp_ns < pushed_from]
    others = [j for j in range(4) if j != joint]
    assert len(pushed) > 100 and all(c[joint] and not c[others].any() for c in pushed)
    assert len(quiet) > 100 and not any(c.any() for c in quiet)
    assert session.summary(run).contacts == len(pushed)
