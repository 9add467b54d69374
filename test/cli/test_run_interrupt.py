"""Ctrl-C on ``scara-ident run``: one ordered stop, a complete bag, a summary, exit 130.

A terminal's Ctrl-C sends SIGINT to its whole foreground process group: the test does
the same to the process group of ``scara-ident run`` (started in a session of its own,
in a ROS domain claimed for this test), while the simulator is publishing. The run must
stop its nodes itself, in order and once each; the bag is then read back and compared
with what the simulator says it published.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.bag import read_joint_states
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.paper.online_results import torque_topic

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from ros_domains import claim_domain  # noqa: E402  (test/ is no package)

pytestmark = [pytest.mark.ros, pytest.mark.slow]

PERIOD_NS = 1_000_000  # the simulator's 1 kHz
START_TIMEOUT = 90.0  # s for the graph to start and the first chunk to reach the bag
RECORD_AFTER_START = 2.0  # s of samples recorded before the Ctrl-C
STOP_TIMEOUT = 90.0  # s for the run to stop its graph and exit after the Ctrl-C


@pytest.fixture(scope='module')
def domain() -> Iterator[str]:
    """A ROS domain of this module's own (an flock, held until the module is done)."""
    value, lock = claim_domain()
    try:
        yield str(value)
    finally:
        lock.close()


def start_run(out: Path, domain: str, log: Path) -> subprocess.Popen[bytes]:
    """``scara-ident run`` for a minute, in a session (process group) of its own."""
    env = {**os.environ, 'ROS_DOMAIN_ID': domain, 'PYTHONUNBUFFERED': '1',
           'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    with log.open('wb') as stream:
        return subprocess.Popen(
            [sys.executable, '-m', 'scara_ident_ros.cli', 'run', '--out', str(out),
             '--duration', '60', '--no-report'],
            stdin=subprocess.DEVNULL, stdout=stream, stderr=subprocess.STDOUT, env=env,
            start_new_session=True)


def wait_for_samples_in_bag(run: subprocess.Popen[bytes], bag: Path, log: Path) -> None:
    """Return once the bag's first chunk (written after at most 1 s of samples) is there."""
    deadline = time.monotonic() + START_TIMEOUT
    while sum(f.stat().st_size for f in bag.glob('*.mcap')) < 20_000:
        assert run.poll() is None, log.read_text()
        assert time.monotonic() < deadline, f'no samples recorded: {log.read_text()}'
        time.sleep(0.2)


#: The graph's processes (one identifier serves every method; its learners are its children)
NODES = ('scara_sim', 'identifier', 'recorder')


def children(pid: int) -> list[int]:
    """The child processes of ``pid`` (Linux)."""
    text = Path(f'/proc/{pid}/task/{pid}/children').read_text()
    return [int(child) for child in text.split()]


def kill_group(run: subprocess.Popen[bytes]) -> None:
    """Whatever happened: SIGKILL the run's group and reap it."""
    try:
        os.killpg(run.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    run.wait()


def test_ctrl_c_stops_the_graph_once_in_order_and_keeps_every_sample(
        tmp_path: Path, domain: str) -> None:
    out, log = tmp_path / 'out', tmp_path / 'run.out'
    run = start_run(out, domain, log)
    try:
        wait_for_samples_in_bag(run, out / 'bag', log)
        time.sleep(RECORD_AFTER_START)
        os.killpg(run.pid, signal.SIGINT)  # as the terminal does: the whole group
        run.wait(timeout=STOP_TIMEOUT)
    finally:
        kill_group(run)
    output = log.read_text()
    assert run.returncode == 130, output
    assert output.count('SIGINT: stopping the graph') == 1, output

    summary = json.loads((out / 'summary.json').read_text())
    assert summary['interrupted'] is True
    assert summary['exit_codes'] == {name: 0 for name in NODES}
    published = summary['joint_states']['published']
    assert 1000 < published < 60_000, summary['joint_states']
    joint_states = read_joint_states(out / 'bag')
    # every sample published is in the bag: none lost at the end, none twice
    assert summary['joint_states']['recorded'] == len(joint_states) == published, \
        summary['joint_states']
    assert (np.diff(joint_states.stamp_ns) == PERIOD_NS).all()
    # the recorder saw one publisher and no gap in the stamps
    assert summary['joint_states']['lost'] == 0 and summary['joint_states']['publishers'] == 1
    for method, row in summary['methods'].items():
        # the identifier took the samples still queued when it was stopped, each method
        # predicted them all, and the recorder (stopped last) recorded every prediction
        assert row['processed'] == row['published'] == row['recorded'] == published, \
            (method, row)
        recorded = read_joint_states(out / 'bag', topic=torque_topic(method))
        assert (recorded.stamp_ns == joint_states.stamp_ns).all(), method
    for name in NODES:
        text = (out / 'logs' / f'{name}.log').read_text()
        assert 'Traceback' not in text, (name, text[-2000:])
    assert f'published {published}, recorded {published}' in output


def test_no_node_outlives_a_killed_run(tmp_path: Path, domain: str) -> None:
    out, log = tmp_path / 'out', tmp_path / 'run.out'
    run = start_run(out, domain, log)
    nodes: list[int] = []
    try:
        wait_for_samples_in_bag(run, out / 'bag', log)
        nodes = children(run.pid)
        assert len(nodes) == len(NODES), nodes
        learners = [pid for node in nodes for pid in children(node)]
        assert len(learners) == len(METHODS), learners  # the identifier's, one per method
        nodes += learners
        run.send_signal(signal.SIGKILL)  # the run alone: its nodes are in other sessions
        run.wait(timeout=10)
        deadline = time.monotonic() + 60
        while any(map(_running, nodes)) and time.monotonic() < deadline:
            time.sleep(0.2)
        alive = [pid for pid in nodes if _running(pid)]
        assert not alive, ('nodes still running after their run was killed: '
                           + '; '.join(map(_describe, alive)))
    finally:
        kill_group(run)
        for pid in filter(_running, nodes):
            os.kill(pid, signal.SIGKILL)


def _describe(pid: int) -> str:
    """``pid``, its command line and its state and signal masks, for a failure message."""
    try:
        command = Path(f'/proc/{pid}/cmdline').read_bytes().replace(b'\0', b' ').decode()
        status = [line for line in Path(f'/proc/{pid}/status').read_text().splitlines()
                  if line.startswith(('State', 'SigBlk', 'SigIgn', 'SigCgt', 'PPid'))]
    except OSError:
        return f'{pid} (gone)'
    return f'{pid} {command.strip()} [{", ".join(status)}]'


def _running(pid: int) -> bool:
    """Whether ``pid`` is a live process (a zombie counts as gone)."""
    try:
        state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != 'Z'
