"""The identifier on an example-robot-data arm's stream with only its URDF (``urdf_file``):
every sample after the q'' warm-up is predicted, though a URDF has no acceleration limits
(the stream's first second gives them) and the Panda's has two finger joints the stream
does not name; one log line says which limits, from where."""
from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

import rostest  # test/nodes/rostest.py

from scara_ident_ros.sim.example_robots import example_robot

pytestmark = [pytest.mark.ros, pytest.mark.slow]

IDENTIFIER = 'scara_ident_ros.nodes.identifier'
ROBOT_SIM = 'scara_ident_ros.nodes.robot_sim'
DURATION = 2.0  # s of samples at 1 kHz: 1 s completes the scaling
N = 2000
LAG = 10  # samples: the centred q'' fit of 21
DEPTH = 5000  # messages: the whole stream fits in the history
DISCOVERY_TIMEOUT = 60.0  # s, the machine is shared (a node took 19 s to refuse a bad
# parameter and exit at load 22)
STREAM_TIMEOUT = 30.0  # s


@pytest.mark.parametrize('robot', ['panda', 'ur5'])
def test_only_a_urdf_predicts_every_sample_after_the_warm_up(
        robot: str, tmp_path: Path, listener: rostest.Listener) -> None:
    torques = listener.subscribe(JointState, '/identified_torque', rostest.reliable(DEPTH))
    listener.subscribe(Float64MultiArray, '/identification_mse')
    stats_file = tmp_path / 'stats.json'
    urdf = example_robot(robot).urdf
    args = ['-p', f'urdf_file:={urdf}', '-p', f'stats_file:={stats_file}',
            '-p', 'wait_for_subscribers:=1', '-p', f'wait_timeout:={DISCOVERY_TIMEOUT}']
    with rostest.NodeProcess(IDENTIFIER, args) as node:
        sim_args = ['-p', f'robot:={robot}', '-p', f'duration:={DURATION}',
                    '-p', 'real_time_factor:=2.0', '-p', 'wait_for_subscribers:=1',
                    '-p', f'wait_timeout:={DISCOVERY_TIMEOUT}']
        with rostest.NodeProcess(ROBOT_SIM, sim_args) as sim:
            listener.spin_until(sim.exited, DISCOVERY_TIMEOUT + 3 * DURATION)
            sim_out = sim.wait(1.0)
        assert sim_out.returncode == 0, sim_out.stderr
        assert listener.spin_until(lambda: len(torques) >= N - LAG, STREAM_TIMEOUT), \
            f'{len(torques)} of {N - LAG} predictions; {node.stderr_so_far()}'
        out = node.stop(signal.SIGINT)
    assert out.returncode == 0 and 'Traceback' not in out.stderr, out.stderr
    info = json.loads(stats_file.read_text())
    assert info['processed'] == info['predicted'] == N and info['skipped'] == {}
    said = [line for line in out.stderr.splitlines() if 'joint limits of' in line]
    assert len(said) == 1, out.stderr
    assert f'position, velocity, effort from {urdf}' in said[0]
    assert "the stream's first 1.00 s (1001 samples)" in said[0]
    assert 'no joint limits' not in out.stderr
