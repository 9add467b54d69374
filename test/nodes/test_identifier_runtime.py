"""The identifier while it runs: parameters set, services called, ``/diagnostics`` heard.

As in ``test_identifier.py``, the node runs in its own process and the test talks to it over
Fast DDS from a fresh rclpy Context: it publishes simulated ``JointState`` samples (stamps
1 ms apart), sets parameters through the node's ``set_parameters`` service (what ``ros2
param set`` calls), calls ``~/save_model`` and ``~/reset`` (``std_srvs/Trigger``) and
listens to ``/diagnostics``. The node's ``stats_file`` is the ground truth of what it learnt.
"""
from __future__ import annotations

import hashlib
import json
import signal
import time
from pathlib import Path
from typing import Any

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rcl_interfaces.msg import ParameterDescriptor
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from scara_ident_ros.sim.simulator import SimRecord

import rostest  # test/nodes/rostest.py
from test_identifier import (DEPTH, DISCOVERY_TIMEOUT, IDENTIFIER,
                             JOINT_STATES_TOPIC, LAG, MSE_TOPIC, PERIOD_NS, SETTLE, T0_NS,
                             TORQUE_TOPIC, held_out_indices, sample_msg, simulated, stamps)

pytestmark = pytest.mark.ros

NODE = '/identifier'
DIAGNOSTICS_TOPIC = '/diagnostics'
STATUS_NAME = '/identifier: identification'
STREAM_TIMEOUT = 60.0  # s for a published stream to come back predicted
OK, WARN, ERROR = b'\x00', b'\x01', b'\x02'  # DiagnosticStatus levels


def sample(record: SimRecord, i: int) -> JointState:
    """Sample ``i`` of ``record``, stamped ``T0_NS + i`` ms."""
    return sample_msg(record, i, T0_NS + i * PERIOD_NS)


def learnt_of(predicted: int) -> int:
    """Samples learnt among the first ``predicted`` predictions (the others held out)."""
    return predicted - len(held_out_indices(predicted))


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


class Session:
    """The test's side of one identifier: samples out; predictions, MSE, diagnostics in."""

    def __init__(self, listener: rostest.Listener, node: rostest.NodeProcess) -> None:
        self.listener = listener
        self.node = node
        qos = rostest.reliable(DEPTH)
        self.publisher = listener.node.create_publisher(JointState, JOINT_STATES_TOPIC, qos)
        self.torques: list[JointState] = []
        self.mse: list[Float64MultiArray] = []
        self.statuses: list[DiagnosticStatus] = []
        self.torque_sub = listener.node.create_subscription(
            JointState, TORQUE_TOPIC, self.torques.append, qos)
        listener.node.create_subscription(Float64MultiArray, MSE_TOPIC, self.mse.append,
                                          rostest.reliable(100))
        listener.node.create_subscription(DiagnosticArray, DIAGNOSTICS_TOPIC, self._diagnostics,
                                          rostest.reliable(100))
        self.sent = 0
        self.dropped = 0  # samples never predicted (pending at a ~/reset)
        matched = listener.spin_until(
            lambda: (self.publisher.get_subscription_count() >= 1
                     and self.torque_sub.get_publisher_count() >= 1 or node.exited()),
            DISCOVERY_TIMEOUT)
        assert not node.exited(), f'node died: {node.stderr_so_far()}'
        assert matched, f'identifier not matched after {DISCOVERY_TIMEOUT} s'
        listener.spin_until(lambda: False, SETTLE)

    def _diagnostics(self, msg: DiagnosticArray) -> None:
        self.statuses += [status for status in msg.status if status.name == STATUS_NAME]

    def send(self, record: SimRecord, n: int) -> None:
        """Publish the next ``n`` samples of ``record``; wait until all but the last ``LAG``
        are predicted."""
        for i in range(self.sent, self.sent + n):
            self.publisher.publish(sample(record, i))
        self.sent += n
        expected = self.sent - LAG - self.dropped
        done = self.listener.spin_until(lambda: len(self.torques) >= expected, STREAM_TIMEOUT)
        assert done, f'{len(self.torques)} of {expected} predictions arrived'

    def trigger(self, service: str) -> Trigger.Response:
        return self.listener.call(Trigger, f'{NODE}/{service}', Trigger.Request())

    def status(self, done: Any, timeout: float = 10.0) -> DiagnosticStatus:
        """The first status from now on for which ``done(status)`` holds."""
        seen = len(self.statuses)
        found = self.listener.spin_until(
            lambda: any(done(s) for s in self.statuses[seen:]), timeout)
        assert found, f'no such status in {timeout} s: {self.statuses[seen:]}'
        return next(s for s in self.statuses[seen:] if done(s))

    def stop(self, tmp_path: Path) -> dict[str, Any]:
        """SIGINT the node (it must exit 0 without a traceback); return its stats_file."""
        assert not self.node.exited(), f'node died: {self.node.stderr_so_far()}'
        out = self.node.stop(signal.SIGINT)
        assert out.returncode == 0, out.stderr
        assert 'Traceback' not in out.stderr, out.stderr
        return json.loads((tmp_path / 'stats.json').read_text())


def start(tmp_path: Path, *params: str) -> rostest.NodeProcess:
    args = ['-p', f'stats_file:={tmp_path / "stats.json"}']
    for param in params:
        args += ['-p', param]
    return rostest.NodeProcess(IDENTIFIER, args)


@pytest.mark.slow
def test_parameters_set_while_running_take_effect(tmp_path: Path,
                                                  listener: rostest.Listener) -> None:
    """learn:=false mid-stream stops learning; bad and read-only values are refused."""
    model = tmp_path / 'model.npz'
    record = simulated(4000)
    with start(tmp_path, f'save_path:={model}', 'checkpoint_period:=0.0') as node:
        session = Session(listener, node)
        session.send(record, 2000)
        assert session.trigger('save_model').success
        learning = digest(model)

        results = listener.set_parameters(NODE, learn=False)
        assert results[0].successful, results[0].reason
        session.send(record, 2000)
        assert session.trigger('save_model').success
        assert digest(model) == learning  # predicted 2000 more samples, learnt none

        refused = listener.set_parameters(NODE, learning_rate=-1.0)[0]
        assert not refused.successful and 'learning_rate' in refused.reason
        refused = listener.set_parameters(NODE, learning_rate='fast')[0]
        assert not refused.successful
        assert refused.reason == "parameter 'learning_rate' must be a number, got 'fast'"
        refused = listener.set_parameters(NODE, hidden_units=10)[0]
        assert not refused.successful and 'read-only' in refused.reason
        fixed, settable = listener.describe_parameters(NODE, 'hidden_units', 'lm_steps')
        assert isinstance(fixed, ParameterDescriptor) and fixed.read_only
        assert "fixed at start: the network's shape" in fixed.description
        assert not settable.read_only and 'settable while running' in settable.description
        seen = len(session.mse)
        listener.spin_until(lambda: False, 2.0)
        assert len(session.mse) - seen <= 25  # 10 Hz
        assert listener.set_parameters(NODE, mse_rate_hz=50.0)[0].successful
        listener.spin_until(lambda: False, 0.5)
        seen = len(session.mse)
        listener.spin_until(lambda: False, 2.0)
        assert len(session.mse) - seen >= 60  # 50 Hz

        for name, value in [('lm_steps', 1), ('lm_interval', 400), ('momentum', 0.2),
                            ('mse_window', 500), ('checkpoint_period', 30.0)]:
            result = listener.set_parameters(NODE, **{name: value})[0]
            assert result.successful, (name, result.reason)
        stats = session.stop(tmp_path)
    # The first 1990 samples were predicted (and learnt, but the held-out ones) before the
    # set; the 10 pending then and the 2000 after it were only predicted.
    assert stats['predicted'] == 4000
    assert stats['learnt'] == learnt_of(2000 - LAG)


@pytest.mark.slow
def test_save_model_and_reset_services(tmp_path: Path, listener: rostest.Listener) -> None:
    model = tmp_path / 'models' / 'model.npz'
    record = simulated(3000)
    # learning in the message path: the model saved after 2000 samples has surely learnt
    # (a learner beside the stream may not have finished its first update by then)
    with start(tmp_path, f'save_path:={model}', 'lm_background:=false') as node:
        session = Session(listener, node)
        no_model = session.trigger('save_model')
        assert not no_model.success and 'no model yet' in no_model.message
        assert not session.trigger('reset').success

        session.send(record, 2000)
        saved = session.trigger('save_model')
        assert saved.success and str(model) in saved.message and model.is_file()
        trained = digest(model)
        reset = session.trigger('reset')
        assert reset.success, reset.message
        assert session.trigger('save_model').success
        assert digest(model) != trained  # fresh weights
        session.dropped = LAG  # the pending samples of before the reset
        session.send(record, 1000)
        stats = session.stop(tmp_path)
    previous, = stats['previous']  # the counters of before the reset, apart
    assert previous['processed'] == 2000 and previous['predicted'] == 2000 - LAG
    assert previous['learnt'] == learnt_of(2000 - LAG)
    assert stats['processed'] == 1000 and stats['predicted'] == 1000
    assert stats['learnt'] == learnt_of(1000)


@pytest.mark.slow
def test_save_model_without_save_path_says_why(tmp_path: Path,
                                               listener: rostest.Listener) -> None:
    with start(tmp_path) as node:
        session = Session(listener, node)
        session.send(simulated(200), 200)
        response = session.trigger('save_model')
        session.stop(tmp_path)
    assert not response.success and 'no save_path' in response.message


@pytest.mark.slow
def test_diagnostics_follow_the_stream(tmp_path: Path, listener: rostest.Listener) -> None:
    """WARN before any sample, OK with figures while fed, ERROR when samples are lost,
    WARN once the samples stop."""
    record = simulated(3100)
    # No validation: a model learning for 3 s predicts held-out samples worse than their
    # mean, which is a WARN of its own (test_health.py).
    with start(tmp_path, 'validation_fraction:=0.0') as node:
        session = Session(listener, node)
        waiting = session.status(lambda s: True)
        assert waiting.level == WARN and 'no sample received yet' in waiting.message
        assert waiting.hardware_id == ''

        fed = None
        deadline = time.monotonic() + 30.0
        while fed is None and time.monotonic() < deadline:  # about 1 kHz, 100 at a time
            for i in range(session.sent, min(session.sent + 100, 3000)):
                session.publisher.publish(sample(record, i))
            session.sent = min(session.sent + 100, 3000)
            listener.spin_until(lambda: False, 0.1)
            fed = next((s for s in session.statuses if s.level == OK), None)
        assert fed is not None, [s.message for s in session.statuses]
        values = {kv.key: kv.value for kv in fed.values}
        assert float(values['samples/s']) > 100
        assert values['lost'] == '0' and values['learning'] == 'true'
        assert int(values['learnt']) > 0

        first = session.sent  # 50 samples, 5 of them never sent: lost on the way
        for i in [*range(first, first + 20), *range(first + 25, first + 50)]:
            session.publisher.publish(sample(record, i))
        lost = session.status(lambda s: s.level == ERROR)
        assert '5 samples lost' in lost.message
        assert {kv.key: kv.value for kv in lost.values}['lost'] == '5'

        stale = session.status(lambda s: s.level == WARN)
        assert 'no sample for' in stale.message and '(> 1 s)' in stale.message
        session.stop(tmp_path)


def test_end_history_after_predicts_the_last_samples_of_a_quiet_stream(
        tmp_path: Path, listener: rostest.Listener) -> None:
    """With end_history_after, the LAG samples pending when the stream goes quiet are
    predicted then, not on stop; the next sample starts a new history, and every sample of
    the two parts is predicted."""
    record = simulated(600)
    with start(tmp_path, 'end_history_after:=0.1', 'trainer:=bp') as node:
        session = Session(listener, node)
        session.send(record, 300)
        assert listener.spin_until(lambda: len(session.torques) == 300, 5.0), \
            f'{len(session.torques)} of 300 predictions before the stop'
        session.send(record, 300)
        assert listener.spin_until(lambda: len(session.torques) == 600, 5.0)
        stats = session.stop(tmp_path)
    assert stamps(session.torques) == [
        T0_NS + i * PERIOD_NS for i in range(600)]
    assert stats['predicted'] == 600 and stats['pending'] == 0
