"""The identifier's contact outputs in its own process, over real rclpy and Fast DDS.

The node predicts with a fixed warm-start model (``learn:=false``): an FFS network whose
output layer is fitted by least squares to the test's stream, so that it identifies it
(validation NMSE below 1e-3) and every external torque can be computed here exactly. The
measured effort carries white noise (5 % of the limits) larger than the model's error, so
that the held-out residuals are independent from sample to sample and 2,500 held-out samples
give far more independent segments than arming needs. The test publishes the stream with a pulse
added to joint1's measured effort on two samples: the first while detection is not armed
(``contact_arm_nmse`` below the model's NMSE), the second once the parameter is raised
above it and a calibration has armed it. The thresholds come from the held-out segments
(``contact_calibration:=held-out``), computed here too; the a-priori residuals, the default,
would hold the first pulse (``test_contact_detector.py`` checks that calibration).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.identification import Holdout, InputStage, JointMap
from scara_ident_ros.identification.contact_detector import HELD_OUT, ContactDetector
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.network import forward_scaled
from scara_ident_ros.nodes.messages import NS_PER_S, ns_to_stamp, stamp_to_ns
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SimConfig, Simulator, make_trajectory

import rostest  # test/nodes/rostest.py
from robot_scaling import robot_scaling  # test/robot_scaling.py

pytestmark = pytest.mark.ros

IDENTIFIER = 'scara_ident_ros.nodes.identifier'
NAMES = ('joint1', 'joint2', 'joint3', 'joint4')
PERIOD_NS = 1_000_000  # 1 kHz
T0_NS = 1_000 * NS_PER_S
N = 6000  # samples: the first PART before arming, the rest after
PART = 5000
LAG = 10  # samples a prediction follows its sample (centred q'', window 21)
PULSES = (4610, 5260)  # samples whose joint1 effort gets PULSE added: before, after arming
PULSE = 150.0  # N·m: over joint1's threshold (about 7 noise std, checked below)
NOISE = 0.05  # effort noise, fraction of the effort limits
BLOCK, FRACTION = 20, 0.5  # held-out blocks (segments of 20): 125 in the first part
TIMEOUT = 30.0  # s, the machine is shared
SCARA = ScaraParams.from_yaml(config_path('scara.yaml'))
LATCHED = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)  # contact_armed's


def stream() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Stamps (N,), q, q', clean measured effort (N, 4) of the simulated SCARA."""
    record = Simulator(SCARA, make_trajectory('standard', SCARA, seed=0),
                       SimConfig(seed=0)).simulate(N)
    stamps = T0_NS + PERIOD_NS * np.arange(N, dtype=np.int64)
    return stamps, record.q, record.qd, record.effort


def fitted_model(path: Path, X: np.ndarray, Y: np.ndarray) -> FeedForwardNet:
    """An FFS network for the SCARA's limits, its output layer fitted to (X, Y), saved."""
    net = make_network('ffs', 4)
    net.set_scaling(*robot_scaling(SCARA))
    hidden = forward_scaled(net, net.x_scaling.transform(X)).h
    design = np.hstack([hidden, np.ones((len(X), 1))])
    weights, *_ = np.linalg.lstsq(design, net.y_scaling.transform(Y), rcond=None)
    theta = net.get_theta()
    net.unpack(theta)[1][:] = weights.T
    net.set_theta(theta)
    net.metadata['joint_names'] = np.array(NAMES)
    net.save(path)
    return net


def message(stamp_ns: int, q: np.ndarray, qd: np.ndarray, effort: np.ndarray) -> JointState:
    msg = JointState()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.name = list(NAMES)
    msg.position, msg.velocity, msg.effort = (
        [float(v) for v in a] for a in (q, qd, effort))
    return msg


def contact_value(diagnostics: list[DiagnosticArray]) -> str | None:
    """The latest 'contact detection' value reported on /diagnostics."""
    for array in reversed(diagnostics):
        for status in array.status:
            for pair in status.values:
                if pair.key == 'contact detection':
                    return str(pair.value)
    return None


def armed_values(messages: list[Bool]) -> list[bool]:
    return [bool(msg.data) for msg in messages]


def diagnostic_values(diagnostics: list[DiagnosticArray]) -> dict[str, str]:
    """The latest identification status's values by key."""
    for array in reversed(diagnostics):
        for status in array.status:
            values = {pair.key: str(pair.value) for pair in status.values}
            if 'contact detection' in values:
                return values
    return {}


def test_contact_only_once_armed_with_the_samples_stamp(tmp_path: Path,
                                                        listener: rostest.Listener) -> None:
    stamps, q, qd, effort = stream()
    _, X, _ = InputStage(JointMap(NAMES)).batch(stamps, NAMES, q, qd, effort)
    net = fitted_model(tmp_path / 'model.npz', X, effort)
    noise = np.random.default_rng(0).normal(size=effort.shape) * NOISE * SCARA.array(
        'effort_max')
    measured = effort + noise
    measured[list(PULSES), 0] += PULSE
    external = measured - net.predict(X)
    # the node's calibration once armed, computed here: the held-out segments of the first
    # part (the node's have a few more samples by then, which changes them a little)
    rule = Holdout(12, 4, fraction=FRACTION, block=BLOCK, seed=0)
    held = [i for i in range(N) if rule.held_out(i)]
    assert not set(PULSES) & set(held)  # a pulse is never among the thresholds' samples
    for i in range(PART):
        if rule.held_out(i):
            rule.add(X[i], measured[i])
    assert rule.segments is not None
    segments = rule.segments
    expected = ContactDetector(4, arm_nmse=0.01, calibrate_on=HELD_OUT)
    calibration = expected.calibrate(
        segments.Y - net.predict(segments.X.reshape(-1, 12)).reshape(segments.Y.shape),
        1e-4, inputs=segments.X)
    assert expected.armed, calibration.why_not
    assert calibration.thresholds is not None and calibration.centre is not None
    clean = np.ones(N, bool)
    clean[list(PULSES)] = False
    margin = np.abs(external - calibration.centre) / calibration.thresholds
    assert margin[clean].max() < 0.7  # no contact but the pulses, whatever the calibration
    assert margin[list(PULSES), 0].min() > 1.3  # a pulse is over joint1's threshold,
    assert margin[list(PULSES), 1:].max() < 0.7  # not the others'

    qos = rostest.reliable(N + 100)
    publisher = listener.node.create_publisher(JointState, '/joint_states', qos)
    externals = listener.subscribe(JointState, '/external_torque', qos)
    contacts = listener.subscribe(JointState, '/contact', qos)
    armed = listener.subscribe(Bool, '/contact_armed', LATCHED)
    diagnostics = listener.subscribe(DiagnosticArray, '/diagnostics', rostest.reliable(100))
    args = ['-p', f'model_path:={tmp_path / "model.npz"}', '-p', 'learn:=false',
            '-p', f'validation_block:={BLOCK}', '-p', f'validation_fraction:={FRACTION}',
            '-p', 'contact_calibration_period:=0.3', '-p', 'contact_arm_nmse:=1e-9',
            '-p', 'contact_calibration:=held-out',
            '-p', f'stats_file:={tmp_path / "stats.json"}']
    with rostest.NodeProcess(IDENTIFIER, args) as node:
        assert listener.spin_until(lambda: publisher.get_subscription_count() >= 1
                                   or node.exited(), TIMEOUT), 'identifier not matched'
        assert not node.exited(), node.stderr_so_far()
        listener.spin_until(lambda: False, 1.0)  # its publishers learn of our subscribers
        for i in range(PART):
            publisher.publish(message(int(stamps[i]), q[i], qd[i], measured[i]))
        assert listener.spin_until(lambda: len(externals) >= PART - LAG, TIMEOUT)
        # the model identifies (NMSE < 1e-3) but not below contact_arm_nmse: not armed
        assert listener.spin_until(
            lambda: 'validation NMSE' in (contact_value(diagnostics) or ''), TIMEOUT)
        assert (contact_value(diagnostics) or '').startswith('not armed')
        assert contacts == [] and armed_values(armed) == [False]
        results = listener.set_parameters('identifier', contact_arm_nmse=1.0)  # the noise's
        assert all(result.successful for result in results)
        assert listener.spin_until(lambda: contact_value(diagnostics) == 'armed', TIMEOUT), \
            contact_value(diagnostics)
        assert listener.spin_until(lambda: armed_values(armed) == [False, True], TIMEOUT)
        values = diagnostic_values(diagnostics)
        assert float(values['contact false alarms/h (estimated)']) <= 1.0
        assert float(values['contact independent segments']) >= 100
        assert values['contact held (outside envelope)'] == '0'
        assert ' / ' in values['contact delay p50 / p99 [ms]']
        for i in range(PART, N):
            publisher.publish(message(int(stamps[i]), q[i], qd[i], measured[i]))
        assert listener.spin_until(lambda: len(externals) >= N - LAG, TIMEOUT)
        listener.spin_until(lambda: False, 0.5)  # nothing more may come
        out = node.stop()
        assert out.returncode == 0 and 'Traceback' not in out.stderr, out.stderr
    listener.spin_until(lambda: len(externals) >= N, 5.0)  # the last LAG, on shutdown

    # external_torque: measured − predicted of every sample, with its stamp
    assert [stamp_to_ns(msg.header.stamp) for msg in externals] == stamps.tolist()
    np.testing.assert_allclose([msg.effort for msg in externals], external, rtol=1e-9,
                               atol=1e-9)
    # contact: only the pulse after arming, on its joint, with its sample's stamp
    assert [stamp_to_ns(msg.header.stamp) for msg in contacts] == [int(stamps[PULSES[1]])]
    assert list(contacts[0].name) == ['joint1']
    assert list(contacts[0].effort) == [externals[PULSES[1]].effort[0]]  # the same τ_ext
    info = json.loads((tmp_path / 'stats.json').read_text())
    assert info['contacts'] == 1 and info['contact_armed'] and info['contact_held'] == 0
    np.testing.assert_allclose(info['contact_thresholds'], calibration.thresholds, rtol=0.3)
    assert info['contact_delay_p50_ms'] is not None and info['contact_delay_p99_ms'] is not None
