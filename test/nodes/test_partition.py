"""Two hosts and a network partition between ``scara_sim`` and a recorder.

The test makes two network namespaces joined by a veth pair, with addresses that exist
only inside them: "host" A runs the simulator, "host" B the recorder. Each finds the
other through ``ROS_STATIC_PEERS`` (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``: no
multicast) and Fast DDS's UDP transport only (``FASTDDS_BUILTIN_TRANSPORTS=UDPv4``: two
hosts share no memory). While the simulator publishes, host A's end of the link goes
down for a while and comes back:

- 5 s (issue 11: "a partition of up to 5 s loses nothing"), well inside the simulator's
  default history (``HISTORY``, 10 s of samples): the reliable recorder gets every sample
  once the link is back; nothing is lost.
- 4 s longer than the history (a history of ``LONG_HISTORY``, shorter than the default
  to keep the test short): the samples that fell out of it are lost (about 4 s of
  them, no more: the history keeps what it should), and the recorder counts them (``lost``
  in its counters, from the gap in the stamps) and says so. "About": the link is down for
  as long as the two ``ip`` commands say (a loaded machine stretches it), and a reliable
  writer may wait up to its heartbeat period (``HEARTBEAT``) after the link is back before
  it resends; samples published meanwhile push more of the history out. Measured on an
  idle machine (10 s history, 14 s partition): 4014-4015 lost in 5 runs; in one CI run, 5022.

The simulator publishes ``PARTITION_AFTER`` s of samples before the partition and
``AFTER_PARTITION`` s after it, with its default QoS.

Making namespaces takes root (CI runs as root); the tests are skipped otherwise.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

from scara_ident_ros.nodes.scara_sim import HISTORY

pytestmark = [pytest.mark.ros,
    pytest.mark.slow,
    pytest.mark.skipif(os.geteuid() != 0,
                       reason='network namespaces (ip netns add) need root; CI runs as root'),
]

RATE_HZ = 1000  # the simulator's default
PARTITION_AFTER = 3.0  # s of samples before the link goes down
AFTER_PARTITION = 4.0  # s of samples after the link is back
SHORT_PARTITION = 5.0  # s: loses nothing with the default history
LONG_HISTORY = 4.0  # s of history in the long run: above HEARTBEAT, below the default
LONG_PARTITION = LONG_HISTORY + 4.0  # s: outlasts that history by 4 s
HEARTBEAT = 3.0  # s: Fast DDS's default heartbeat period of a reliable writer (the simulator's)
START_TIMEOUT = 60.0  # s for the two to discover each other (shared machine)
END_TIMEOUT = 90.0  # s for the simulator to publish everything and exit
STOP_TIMEOUT = 30.0  # s for the recorder to close its bag after SIGINT


@dataclass(frozen=True)
class Host:
    """A network namespace with one end of the veth pair."""

    namespace: str
    link: str
    address: str

    def command(self, *argv: str) -> list[str]:
        """``argv`` run inside this namespace."""
        return ['ip', 'netns', 'exec', self.namespace, *argv]


def _ip(*argv: str) -> None:
    subprocess.run(['ip', *argv], check=True, capture_output=True, timeout=30)


@contextmanager
def two_hosts() -> Iterator[tuple[Host, Host]]:
    """Two namespaces joined by a veth pair (10.213.N.1 and .2/24); deleted on the way out."""
    tag = os.getpid() % 10_000
    subnet = f'10.213.{tag % 250}'
    hosts = (Host(f'scara-a-{tag}', f'sca{tag}', f'{subnet}.1'),
             Host(f'scara-b-{tag}', f'scb{tag}', f'{subnet}.2'))
    created: list[str] = []
    try:
        for host in hosts:
            _ip('netns', 'add', host.namespace)
            created.append(host.namespace)
        _ip('link', 'add', hosts[0].link, 'type', 'veth', 'peer', 'name', hosts[1].link)
        for host in hosts:
            _ip('link', 'set', host.link, 'netns', host.namespace)
            _ip('-n', host.namespace, 'addr', 'add', f'{host.address}/24', 'dev', host.link)
            _ip('-n', host.namespace, 'link', 'set', 'lo', 'up')
            _ip('-n', host.namespace, 'link', 'set', host.link, 'up')
        yield hosts
    finally:
        for namespace in created:  # deleting a namespace deletes its end of the pair
            subprocess.run(['ip', 'netns', 'del', namespace], check=False, timeout=30)


def start(host: Host, peer: Host, module: str, ros_args: list[str],
          log: Path) -> subprocess.Popen[bytes]:
    """``python -m module`` on ``host``, finding its peer by ROS_STATIC_PEERS only."""
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'ROS_STATIC_PEERS': peer.address, 'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4',
           'PYTHONUNBUFFERED': '1', 'RCUTILS_LOGGING_BUFFERED_STREAM': '0'}
    with log.open('wb') as stream:
        return subprocess.Popen(
            host.command(sys.executable, '-m', module, '--ros-args', *ros_args),
            stdin=subprocess.DEVNULL, stdout=stream, stderr=subprocess.STDOUT, env=env)


def wait_for(text: str, log: Path, process: subprocess.Popen[bytes]) -> None:
    deadline = time.monotonic() + START_TIMEOUT
    while text not in log.read_text(errors='replace'):
        assert process.poll() is None, log.read_text(errors='replace')
        assert time.monotonic() < deadline, f'no {text!r}: {log.read_text(errors="replace")}'
        time.sleep(0.1)


def samples(partition: float) -> int:
    """Samples the simulator publishes in a run with a partition of ``partition`` s."""
    return round((PARTITION_AFTER + partition + AFTER_PARTITION) * RATE_HZ)


def record_across_a_partition(tmp_path: Path, seconds: float,
                              history: float = HISTORY) -> tuple[dict, dict, str, float]:
    """Simulator on A (``history`` s of history), recorder on B, A's link down for
    ``seconds`` while publishing.

    Returns the simulator's and the recorder's final counters, the recorder's log and the
    longest the link can have been down (s): from before the ``down`` command to after the
    ``up`` command returned.
    """
    duration = samples(seconds) / RATE_HZ
    sim_stats, recorder_stats = tmp_path / 'sim.json', tmp_path / 'recorder.json'
    sim_log, recorder_log = tmp_path / 'sim.log', tmp_path / 'recorder.log'
    with two_hosts() as (a, b):
        recorder = start(b, a, 'scara_ident_ros.nodes.recorder', [
            '-p', f'output:={tmp_path / "bag"}', '-p', "topics:=['/joint_states']",
            '-p', f'stats_file:={recorder_stats}', '-p', 'discovery_period:=0.2'],
            recorder_log)
        sim = start(a, b, 'scara_ident_ros.nodes.scara_sim', [
            '-p', f'duration:={duration}', '-p', 'wait_for_subscribers:=1',
            '-p', f'wait_timeout:={START_TIMEOUT}', '-p', f'stats_file:={sim_stats}',
            '-p', f'history:={history}'],
            sim_log)
        try:
            # subscribed (not only 'recording /joint_states into BAG', logged before the
            # publisher is found): the simulator, waiting for it, starts publishing now
            wait_for('recording /joint_states (', recorder_log, recorder)
            time.sleep(PARTITION_AFTER)
            down = time.monotonic()
            _ip('-n', a.namespace, 'link', 'set', a.link, 'down')
            time.sleep(seconds)
            _ip('-n', a.namespace, 'link', 'set', a.link, 'up')
            partition = time.monotonic() - down
            assert sim.wait(timeout=END_TIMEOUT) == 0, sim_log.read_text()
            recorder.send_signal(signal.SIGINT)
            assert recorder.wait(timeout=STOP_TIMEOUT) == 0, recorder_log.read_text()
        finally:
            for process in (sim, recorder):
                if process.poll() is None:
                    process.kill()
                    process.wait()
    return (json.loads(sim_stats.read_text()), json.loads(recorder_stats.read_text()),
            recorder_log.read_text(errors='replace'), partition)


def test_a_five_second_partition_loses_nothing(tmp_path: Path) -> None:
    sim, recorder, log, _ = record_across_a_partition(tmp_path, SHORT_PARTITION)
    total = samples(SHORT_PARTITION)
    assert sim['published'] == total, sim
    assert recorder['topics'] == {'/joint_states': total}, (recorder, log)
    assert recorder['lost'] == {'/joint_states': 0}, recorder


def test_a_partition_longer_than_the_history_is_counted_as_lost(tmp_path: Path) -> None:
    sim, recorder, log, partition = record_across_a_partition(tmp_path, LONG_PARTITION,
                                                                LONG_HISTORY)
    total = samples(LONG_PARTITION)
    assert sim['published'] == total, sim
    written = recorder['topics']['/joint_states']
    lost = recorder['lost']['/joint_states']
    assert written < total and lost > 0, (recorder, log)
    assert written + lost == total, recorder  # every missing sample counted, once
    # what the partition outlasts the history by, and what is published until the writer's
    # next heartbeat; below the 8 s of samples lost if the history kept nothing
    assert lost <= (partition - LONG_HISTORY + HEARTBEAT) * RATE_HZ, (recorder, partition)
    assert f'/joint_states: {lost} samples lost' in log, log
