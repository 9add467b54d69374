"""The identifier node in its own process, over real rclpy and Fast DDS.

Each test starts ``python -m scara_ident_ros.nodes.identifier --ros-args ...`` and talks to
it from a fresh rclpy Context (:class:`rostest.Listener`): either the test publishes the
``JointState`` samples itself (values from the simulator core, stamps 1 ms apart) or a
``scara_sim`` process does. The node's ``stats_file`` JSON is the ground truth for what it
processed, learnt and skipped.
"""
from __future__ import annotations

import hashlib
import json
import math
import signal
import sys
from collections import Counter
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification import Differentiator
from scara_ident_ros.methods import limit_scaling, make_network
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nodes.messages import NS_PER_S, ns_to_stamp, stamp_to_ns
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory
from scara_ident_ros.sim.simulator import SimRecord

sys.path.insert(0, str(Path(__file__).resolve().parent))
import rostest  # noqa: E402  (test/nodes is not a package: see rostest's docstring)

IDENTIFIER = 'scara_ident_ros.nodes.identifier'
SCARA_SIM = 'scara_ident_ros.nodes.scara_sim'
JOINT_STATES_TOPIC = '/joint_states'
TORQUE_TOPIC = '/identified_torque'
MSE_TOPIC = '/identification_mse'
NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
PERIOD_NS = 1_000_000  # 1 kHz
T0_NS = 1_000 * NS_PER_S  # stamp of the test's first sample
DEPTH = 20_000  # messages: every test's whole stream fits in the history
DISCOVERY_TIMEOUT = 20.0  # s, the machine is shared
STREAM_TIMEOUT = 30.0  # s for a published stream to come back processed
SETTLE = 1.0  # s after discovery on our side, for the node's side (see Feed.wait_for)


# ---------------------------------------------------------------------------------- helpers
def simulated(n: int, seed: int = 0) -> SimRecord:
    """``n`` samples of the simulated SCARA (noise-free, standard excitation) at 1 kHz."""
    params = ScaraParams.from_yaml(config_path('scara.yaml'))
    simulator = Simulator(params, make_trajectory('standard', params, seed=seed),
                          SimConfig(seed=seed))
    return simulator.simulate(n)


def joint_state(stamp_ns: int, names: Sequence[str], position: Sequence[float] = (),
                velocity: Sequence[float] = (), effort: Sequence[float] = ()) -> JointState:
    """A JointState with exactly these (possibly inconsistent or non-finite) arrays."""
    msg = JointState()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.name = list(names)
    msg.position = [float(v) for v in position]
    msg.velocity = [float(v) for v in velocity]
    msg.effort = [float(v) for v in effort]
    return msg


def sample_msg(record: SimRecord, i: int, stamp_ns: int,
               order: Sequence[int] = (0, 1, 2, 3)) -> JointState:
    """Sample ``i`` of ``record`` with joints in message order ``order``."""
    idx = list(order)
    return joint_state(stamp_ns, [NAMES[j] for j in idx], record.q[i, idx],
                       record.qd[i, idx], record.effort[i, idx])


def identifier(tmp_path: Path, *params: str, name: str = 'run') -> rostest.NodeProcess:
    """Start the identifier with a ``stats_file`` in ``tmp_path`` and extra ``-p`` params."""
    args = ['-p', f'stats_file:={tmp_path / (name + "_stats.json")}']
    for param in params:
        args += ['-p', param]
    return rostest.NodeProcess(IDENTIFIER, args)


def stop(node: rostest.NodeProcess) -> rostest.NodeOutput:
    """SIGINT the node; it must exit 0 without a traceback."""
    assert not node.exited(), f'node died: {node.stderr_so_far()}'
    out = node.stop(signal.SIGINT)
    assert out.returncode == 0, out.stderr
    assert 'Traceback' not in out.stderr, out.stderr
    return out


def stats(tmp_path: Path, name: str = 'run') -> dict[str, Any]:
    return json.loads((tmp_path / (name + '_stats.json')).read_text())


def stamps(msgs: Sequence[JointState]) -> list[int]:
    return [stamp_to_ns(msg.header.stamp) for msg in msgs]


class Feed:
    """The test's side of one identifier: a ``joint_states`` publisher, torque and MSE lists."""

    def __init__(self, listener: rostest.Listener, *, namespace: str = '') -> None:
        self.listener = listener
        qos = rostest.reliable(DEPTH)
        self.publisher = listener.node.create_publisher(JointState, JOINT_STATES_TOPIC, qos)
        self.torques: list[JointState] = []
        self.mse: list[Float64MultiArray] = []
        self.torque_sub = listener.node.create_subscription(
            JointState, namespace + TORQUE_TOPIC, self.torques.append, qos)
        listener.node.create_subscription(Float64MultiArray, namespace + MSE_TOPIC,
                                          self.mse.append, rostest.reliable(100))

    def wait_for(self, node: rostest.NodeProcess) -> None:
        """Wait until the node subscribes to our samples and we to its predictions."""
        matched = self.listener.spin_until(
            lambda: (self.publisher.get_subscription_count() >= 1
                     and self.torque_sub.get_publisher_count() >= 1 or node.exited()),
            DISCOVERY_TIMEOUT)
        assert not node.exited(), f'node died: {node.stderr_so_far()}'
        assert matched, f'identifier not matched after {DISCOVERY_TIMEOUT} s'
        # Our side has matched; the node's publisher learns of our subscription from the same
        # discovery but maybe later, and a volatile publisher never resends what it published
        # before: give it a moment (0.2 s once lost 15 predictions at load average 6).
        self.listener.spin_until(lambda: False, SETTLE)

    def wait_gone(self) -> None:
        """After a node stopped: wait until it is unmatched, so the next one is not confused
        with it."""
        gone = self.listener.spin_until(
            lambda: (self.publisher.get_subscription_count() == 0
                     and self.torque_sub.get_publisher_count() == 0), DISCOVERY_TIMEOUT)
        assert gone, 'a stopped identifier is still matched'

    def send(self, msgs: Sequence[JointState], expect_torques: int) -> None:
        """Publish ``msgs`` and wait for ``expect_torques`` predictions in all."""
        for msg in msgs:
            self.publisher.publish(msg)
        done = self.listener.spin_until(lambda: len(self.torques) >= expect_torques,
                                        STREAM_TIMEOUT)
        assert done, f'{len(self.torques)} of {expect_torques} predictions arrived'
        self.listener.spin_until(lambda: False, 0.2)  # nothing more may come
        assert len(self.torques) == expect_torques


@pytest.fixture
def listener() -> Iterator[rostest.Listener]:
    node = rostest.Listener('identifier_test')
    yield node
    node.close()


def model_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ------------------------------------------------------------------------ fed by scara_sim
SIM_DURATION = 10.0  # s of simulated samples
SIM_RATE_FACTOR = 2.0  # simulated s per wall-clock s: 2 kHz of samples


@pytest.mark.slow
def test_learns_from_simulator(tmp_path: Path, listener: rostest.Listener) -> None:
    feed = Feed(listener)
    states = listener.subscribe(JointState, JOINT_STATES_TOPIC, rostest.reliable(DEPTH))
    n = round(SIM_DURATION * NS_PER_S / PERIOD_NS)
    with identifier(tmp_path) as node:
        assert listener.spin_until(lambda: feed.torque_sub.get_publisher_count() >= 1,
                                   DISCOVERY_TIMEOUT), node.stderr_so_far()
        listener.spin_until(lambda: False, SETTLE)  # see Feed.wait_for
        sim_args = ['-p', f'duration:={SIM_DURATION}', '-p', f'real_time_factor:='
                    f'{SIM_RATE_FACTOR}', '-p', 'wait_for_subscribers:=2',
                    '-p', f'wait_timeout:={DISCOVERY_TIMEOUT}']
        with rostest.NodeProcess(SCARA_SIM, sim_args) as sim:
            listener.spin_until(sim.exited,
                                DISCOVERY_TIMEOUT + 3 * SIM_DURATION)
            sim_out = sim.wait(1.0)
        assert sim_out.returncode == 0, sim_out.stderr
        assert f'published {n} samples' in sim_out.stderr
        assert listener.spin_until(lambda: len(feed.torques) >= n - 1, STREAM_TIMEOUT), \
            f'{len(feed.torques)} of {n - 1} predictions'
        seen = len(feed.mse)  # the next-but-one MSE message covers the whole stream
        assert listener.spin_until(lambda: len(feed.mse) >= seen + 2, 5.0)
        stop(node)
    info = stats(tmp_path)
    assert info['processed'] == n
    assert info['predicted'] == info['learned'] == n - 1
    assert info['skipped'] == {'warming_up': 1}
    assert len(states) == n, 'the test itself lost joint states'

    # Every prediction answers one input sample, in order, in joint order.
    efforts = {stamp_to_ns(msg.header.stamp): np.array(msg.effort) for msg in states}
    torque_stamps = stamps(feed.torques)
    assert torque_stamps == stamps(states)[1:]
    assert all(tuple(msg.name) == NAMES for msg in feed.torques)
    predicted = np.array([msg.effort for msg in feed.torques])
    assert predicted.shape == (n - 1, 4) and np.isfinite(predicted).all()

    # The error falls: the first 1000 predictions against the last 1000.
    measured = np.array([efforts[stamp] for stamp in torque_stamps])
    squared = (measured - predicted) ** 2
    early, late = squared[:1000].mean(axis=0), squared[-1000:].mean(axis=0)
    assert late.mean() < early.mean() / 10, (early, late)

    # identification_mse: the documented layout, falling, and its last value is the MSE
    # of the last mse_window (1000) predictions.
    first, last = feed.mse[0], feed.mse[-1]
    assert [(d.label, d.size) for d in last.layout.dim] == [
        ('metric:mse,nmse', 2), ('joint:joint1,joint2,joint3,joint4,total', 5)]
    assert len(last.data) == 10
    assert last.data[4] < first.data[4] / 10
    np.testing.assert_allclose(last.data[:4], late, rtol=1e-6)
    assert last.data[4] == pytest.approx(late.mean(), rel=1e-6)
    variance = measured[-1000:].var(axis=0)
    np.testing.assert_allclose(last.data[5:9], late / variance, rtol=1e-6)
    assert info['mse_total'] == pytest.approx(last.data[4], rel=1e-9)


# ------------------------------------------------------------------------ the hostile stream
GOOD_BETWEEN = 5  # good samples after each bad one
CYCLES = 3  # times the whole list of bad inputs is sent


def hostile_stream(record: SimRecord) -> tuple[list[JointState], Counter[str], list[int]]:
    """Good samples interleaved with every kind of bad input.

    Returns the messages, the skip reasons they must be counted under (warm-up included)
    and the stamps of the samples that must be predicted, in order.
    """
    msgs: list[JointState] = []
    reasons: Counter[str] = Counter()
    predicted: list[int] = []
    slot = 0  # index into record, one per published message (stamps 1 ms apart)
    offset = T0_NS  # moved by the clock jumps
    last_good = None  # stamp of the last accepted sample
    warm = False  # the differentiator has a history

    def stamp() -> int:
        return offset + slot * PERIOD_NS

    def good(order: Sequence[int] = (0, 1, 2, 3), reason: str | None = None) -> None:
        nonlocal slot, last_good, warm
        msgs.append(sample_msg(record, slot, stamp(), order))
        if reason is not None or not warm:
            reasons[reason or 'warming_up'] += 1
        else:
            predicted.append(stamp())
        last_good, warm = stamp(), True
        slot += 1

    def bad(reason: str, names: Sequence[str], position: Sequence[float],
            velocity: Sequence[float], effort: Sequence[float],
            at: int | None = None) -> None:
        nonlocal slot
        msgs.append(joint_state(stamp() if at is None else at, names, position, velocity,
                                effort))
        reasons[reason] += 1
        slot += 1

    def corrupt(reason: str, field: int, index: int, value: float) -> None:
        arrays = [record.q[slot].copy(), record.qd[slot].copy(), record.effort[slot].copy()]
        arrays[field][index] = value
        bad(reason, NAMES, *arrays)

    for _ in range(50):
        good()
    for _ in range(CYCLES):
        q, qd, e = record.q[slot], record.qd[slot], record.effort[slot]
        cases = [
            lambda: corrupt('non_finite', 0, 1, math.nan),
            lambda: corrupt('non_finite', 0, 0, math.inf),
            lambda: corrupt('non_finite', 1, 2, math.nan),
            lambda: corrupt('non_finite', 1, 3, -math.inf),
            lambda: corrupt('non_finite', 2, 0, math.nan),
            lambda: corrupt('non_finite', 2, 3, math.inf),
            lambda: bad('no_velocity', NAMES, q, (), e),
            lambda: bad('no_position', NAMES, (), qd, e),
            lambda: bad('no_effort', NAMES, q, qd, ()),  # learning needs the effort
            lambda: bad('length_mismatch', NAMES, q[:3], qd, e),
            lambda: bad('length_mismatch', NAMES, q, qd, [*e, 1.0]),
            lambda: bad('unknown_joint', [*NAMES[:3], 'joint5'], q, qd, e),
            lambda: bad('unknown_joint', [*NAMES, 'joint5'], [*q, 0.0], [*qd, 0.0],
                        [*e, 0.0]),
            lambda: bad('missing_joint', NAMES[:3], q[:3], qd[:3], e[:3]),
            lambda: bad('duplicate_joint', [*NAMES[:3], 'joint1'], q, qd, e),
            lambda: good(order=(3, 1, 0, 2)),  # another order: mapped by name, not skipped
            lambda: bad('stamp_repeated', NAMES, q, qd, e, at=last_good),
            lambda: bad('stamp_backwards', NAMES, q, qd, e, at=last_good - 5 * PERIOD_NS),
        ]
        for case in cases:
            case()
            for _ in range(GOOD_BETWEEN):
                good()
        offset += NS_PER_S  # a clock jump forwards (lost samples) ...
        good(reason='gap')
        for _ in range(GOOD_BETWEEN):
            good()
        offset -= 2 * NS_PER_S  # ... and backwards (a replay restarted)
        good(reason='gap')
        for _ in range(GOOD_BETWEEN):
            good()
    return msgs, reasons, predicted


def test_survives_hostile_stream(tmp_path: Path, listener: rostest.Listener) -> None:
    record = simulated(1000)
    msgs, reasons, predicted = hostile_stream(record)
    model = tmp_path / 'hostile.npz'
    feed = Feed(listener)
    with identifier(tmp_path, f'save_path:={model}') as node:
        feed.wait_for(node)
        feed.send(msgs, len(predicted))
        stop(node)
    info = stats(tmp_path)
    assert info['processed'] == len(msgs)
    assert info['skipped'] == dict(reasons)
    assert info['predicted'] == info['learned'] == len(predicted)
    assert stamps(feed.torques) == predicted
    assert all(tuple(msg.name) == NAMES for msg in feed.torques)
    assert np.isfinite([msg.effort for msg in feed.torques]).all()
    assert np.isfinite(info['mse']).all()
    network = FeedForwardNet.load(model)  # refuses non-finite weights; check anyway
    assert np.isfinite(network.get_params()).all()
    assert [str(n) for n in network.metadata['joint_names']] == list(NAMES)


def test_bad_samples_before_the_first_good_one(tmp_path: Path,
                                               listener: rostest.Listener) -> None:
    """Without joint_names the joints are those of the first *valid* sample; the invalid
    samples before it are counted like any other."""
    record = simulated(30)
    q, qd, e = record.q[0], record.qd[0], record.effort[0]
    msgs = [
        joint_state(T0_NS, NAMES[:3], [math.nan, *q[1:3]], qd[:3], e[:3]),  # 3 joints, NaN
        joint_state(T0_NS + 1, [*NAMES[:3], 'joint1'], q, qd, e),
        joint_state(T0_NS + 2, NAMES, q, (), e),
        joint_state(T0_NS + 3, (), (), (), ()),
        joint_state(T0_NS + 4, NAMES, q[:2], qd, e),
    ]
    msgs += [sample_msg(record, i, T0_NS + (i + 1) * PERIOD_NS) for i in range(25)]
    feed = Feed(listener)
    with identifier(tmp_path) as node:
        feed.wait_for(node)
        feed.send(msgs, 24)
        stop(node)
    info = stats(tmp_path)
    assert info['joint_names'] == list(NAMES)
    assert info['processed'] == 30
    assert info['skipped'] == {'non_finite': 1, 'duplicate_joint': 1, 'no_velocity': 2,
                               'length_mismatch': 1, 'warming_up': 1}
    assert info['predicted'] == info['learned'] == 24


def test_warm_start_without_joint_names_takes_a_sample_of_its_size(
        tmp_path: Path, listener: rostest.Listener) -> None:
    """A model that does not name its joints fixes their number: a first sample with
    another number of joints is skipped (joint_count), not fatal."""
    model = saved_model(tmp_path / 'anonymous.npz', NAMES, record_names=False)
    record = simulated(20)
    msgs = [joint_state(T0_NS, NAMES[:3], record.q[0, :3], record.qd[0, :3],
                        record.effort[0, :3])]
    msgs += [sample_msg(record, i, T0_NS + (i + 1) * PERIOD_NS) for i in range(20)]
    feed = Feed(listener)
    with identifier(tmp_path, f'model_path:={model}') as node:
        feed.wait_for(node)
        feed.send(msgs, 19)
        stop(node)
    info = stats(tmp_path)
    assert info['skipped'] == {'joint_count': 1, 'warming_up': 1}
    assert info['joint_names'] == list(NAMES)


# ------------------------------------------------------------------------------ warm start
def test_warm_start_predicts_without_learning(tmp_path: Path,
                                              listener: rostest.Listener) -> None:
    record = simulated(300)
    trained, replayed = tmp_path / 'trained.npz', tmp_path / 'replayed.npz'
    feed = Feed(listener)
    with identifier(tmp_path, f'save_path:={trained}', name='train') as node:
        feed.wait_for(node)
        feed.send([sample_msg(record, i, T0_NS + i * PERIOD_NS) for i in range(300)], 299)
        stop(node)
    feed.wait_gone()
    assert stats(tmp_path, 'train')['learned'] == 299
    digest = model_digest(trained)

    # The same 150 samples in order, then, after a clock jump, with the joints in another
    # order: a fixed model must predict the same efforts for both, mapped by name.
    n, jump = 150, 10 * NS_PER_S
    order = (2, 0, 3, 1)
    msgs = [sample_msg(record, i, T0_NS + i * PERIOD_NS) for i in range(n)]
    msgs += [sample_msg(record, i, T0_NS + jump + i * PERIOD_NS, order) for i in range(n)]
    feed.torques.clear()
    with identifier(tmp_path, f'model_path:={trained}', 'learn:=false',
                    f'save_path:={replayed}', name='replay') as node:
        feed.wait_for(node)
        feed.send(msgs, 2 * (n - 1))
        stop(node)
    info = stats(tmp_path, 'replay')
    assert info['processed'] == 2 * n
    assert info['predicted'] == 2 * (n - 1)
    assert info['learned'] == 0
    assert info['skipped'] == {'warming_up': 1, 'gap': 1}
    assert model_digest(trained) == digest, 'the warm-start model was written to'

    in_order = np.array([msg.effort for msg in feed.torques[:n - 1]])
    reordered = np.array([msg.effort for msg in feed.torques[n - 1:]])
    assert all(tuple(msg.name) == NAMES for msg in feed.torques)
    assert stamps(feed.torques) == [T0_NS + i * PERIOD_NS for i in range(1, n)] + [
        T0_NS + jump + i * PERIOD_NS for i in range(1, n)]
    np.testing.assert_allclose(reordered, in_order, rtol=1e-12, atol=1e-12)

    # They are the loaded model's own predictions (the node's default differentiator).
    network = FeedForwardNet.load(trained)
    differentiator = Differentiator('lowpass', cutoff_hz=50.0)
    qdd = [differentiator.update(T0_NS + i * PERIOD_NS, record.qd[i]) for i in range(n)]
    x = np.hstack([record.q[1:n], record.qd[1:n], np.array(qdd[1:])])
    np.testing.assert_allclose(in_order, network.predict(x), rtol=1e-9, atol=1e-12)

    # Without learning the model saved on shutdown is the one loaded.
    saved = FeedForwardNet.load(replayed)
    np.testing.assert_array_equal(saved.get_params(), network.get_params())
    assert [str(n) for n in saved.metadata['joint_names']] == list(NAMES)


# ----------------------------------------------------------------------- bad configuration
def saved_model(path: Path, names: Sequence[str], *, record_names: bool = True,
                method: str = 'ffmw') -> Path:
    """Save a fresh network for ``names`` (with them in its metadata, as a node records)."""
    network = make_network(method, len(names))
    limits = ScaraParams.from_yaml(config_path('scara.yaml'))
    index = [NAMES.index(name) for name in names]
    network.set_scaling(*limit_scaling(*(limits.array(name)[index] for name in (
        'position_min', 'position_max', 'velocity_max', 'acceleration_max', 'effort_max'))))
    if record_names:
        network.metadata['joint_names'] = np.array(names)
    network.save(path)
    return path


BAD_CONFIGS = {
    'unknown method': (lambda d: ['method:=foo'], "'method'"),
    'not a model': (lambda d: [f'model_path:={d / "junk.npz"}'], 'junk.npz'),
    'no such model': (lambda d: [f'model_path:={d / "none.npz"}'], 'none.npz'),
    'model for 2 joints': (
        lambda d: [f'model_path:={saved_model(d / "m.npz", NAMES[:2], record_names=False)}',
                   f'joint_names:={list(NAMES)}'], '2 outputs'),
    'model for other joints': (
        lambda d: [f'model_path:={saved_model(d / "m.npz", NAMES[:2])}',
                   f'joint_names:={list(NAMES)}'], "['joint1', 'joint2']"),
    'model for another joint order': (
        lambda d: [f'model_path:={saved_model(d / "m.npz", NAMES)}',
                   f'joint_names:={list(NAMES[::-1])}'], 'in that order'),
    'model of another method': (
        lambda d: [f'model_path:={saved_model(d / "m.npz", NAMES, method="ffs")}'],
        'sigmoid'),
    'mse_window too small': (lambda d: ['mse_window:=10'], 'mse_window'),
    'joint names not strings': (lambda d: ['joint_names:=[1, 2, 3, 4]'], 'joint_names'),
}


@pytest.mark.parametrize('case', list(BAD_CONFIGS))
def test_bad_configuration_is_one_line(tmp_path: Path, case: str) -> None:
    (tmp_path / 'junk.npz').write_text('not a network\n')
    make_params, problem = BAD_CONFIGS[case]
    with identifier(tmp_path, *make_params(tmp_path)) as node:
        out = node.wait(DISCOVERY_TIMEOUT)
    lines = out.stderr.strip().splitlines()
    assert out.returncode == 2, out.stderr
    assert len(lines) == 1, out.stderr
    assert lines[0].startswith('identifier: error: ') and problem in lines[0], lines[0]


# ------------------------------------------------------------------------------ namespacing
def test_namespace_and_remapping(tmp_path: Path, listener: rostest.Listener) -> None:
    record = simulated(50)
    feed = Feed(listener, namespace='/ffs')
    node = rostest.NodeProcess(IDENTIFIER, ['-r', '__ns:=/ffs', '-r',
                                            'joint_states:=/joint_states', '-p', 'method:=ffs'])
    with node:
        feed.wait_for(node)
        feed.send([sample_msg(record, i, T0_NS + i * PERIOD_NS) for i in range(50)], 49)
        assert listener.spin_until(lambda: len(feed.mse) > 0, 5.0)
        assert listener.node.count_publishers(TORQUE_TOPIC) == 0
        out = stop(node)
    assert 'FFS identifier on /joint_states → /ffs/identified_torque' in out.stderr
    assert len(feed.mse[-1].data) == 10


# ------------------------------------------------------------- waiting for its subscribers
def test_waits_for_subscribers_of_both_outputs_before_subscribing(
        tmp_path: Path, listener: rostest.Listener) -> None:
    states = listener.node.create_publisher(JointState, JOINT_STATES_TOPIC,
                                            rostest.reliable(DEPTH))
    with identifier(tmp_path, 'wait_for_subscribers:=1',
                    f'wait_timeout:={3 * DISCOVERY_TIMEOUT}') as node:
        node.wait_for_stderr('waiting for 1 subscriber(s) on /identified_torque and '
                             '/identification_mse', DISCOVERY_TIMEOUT)
        early = listener.spin_until(lambda: states.get_subscription_count() > 0, 2.0)
        assert not early, 'subscribed joint_states before anyone heard its outputs'
        listener.subscribe(JointState, TORQUE_TOPIC, rostest.reliable(DEPTH))
        early = listener.spin_until(lambda: states.get_subscription_count() > 0, 2.0)
        assert not early, 'subscribed joint_states before identification_mse was heard'
        listener.subscribe(Float64MultiArray, MSE_TOPIC, rostest.reliable(100))
        assert listener.spin_until(lambda: states.get_subscription_count() > 0,
                                   DISCOVERY_TIMEOUT), node.stderr_so_far()
        out = stop(node)
    assert 'subscribing anyway' not in out.stderr


def test_subscribes_anyway_after_wait_timeout(tmp_path: Path,
                                              listener: rostest.Listener) -> None:
    states = listener.node.create_publisher(JointState, JOINT_STATES_TOPIC,
                                            rostest.reliable(DEPTH))
    with identifier(tmp_path, 'wait_for_subscribers:=2', 'wait_timeout:=1.0') as node:
        assert listener.spin_until(lambda: states.get_subscription_count() > 0,
                                   DISCOVERY_TIMEOUT), node.stderr_so_far()
        out = stop(node)
    assert 'only 0 of 2 subscribers on the outputs after 1 s; subscribing anyway' in out.stderr
