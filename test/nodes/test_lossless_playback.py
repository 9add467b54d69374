"""``play --rate max`` into a slower subscriber loses nothing, and says what it delivered.

The shipped ``bags/demo_run`` holds 10,000 ``/joint_states`` of the simulator. Played as
fast as possible into an identifier (its own process, default lm trainer: far slower than
the player), every sample must be processed: the player waits for acknowledgements
before its history could overwrite one, the identifier's keep-all subscription only
acknowledges what it has room for, and on SIGINT (sent as soon as the player is done)
the identifier takes what is still queued before it closes.
"""
from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from rostest import NodeProcess  # test/nodes/rostest.py

HERE = Path(__file__).resolve().parent

pytestmark = [pytest.mark.ros, pytest.mark.slow]

BAG = HERE.parents[1] / 'bags' / 'demo_run'
SAMPLES = 10_000  # /joint_states in BAG
IDENTIFIER = 'scara_ident_ros.nodes.identifier'
PLAYER = 'scara_ident_ros.nodes.player'
START_TIMEOUT = 60.0  # s for a node to start (the machine is shared)
PLAY_TIMEOUT = 180.0  # s for the bag to be played into the identifier
STOP_TIMEOUT = 60.0  # s for the identifier to take its queue and close


def test_play_at_rate_max_into_an_identifier_loses_no_sample(tmp_path: Path) -> None:
    stats = tmp_path / 'identifier.json'
    with NodeProcess(IDENTIFIER, ['-p', f'stats_file:={stats}']) as identifier:
        identifier.wait_for_stderr('identifier on', START_TIMEOUT)
        played = subprocess.run(
            [sys.executable, '-m', 'scara_ident_ros.cli', 'play', str(BAG), '--rate', 'max',
             '--topics', '/joint_states', '--wait-timeout', '30'],
            capture_output=True, text=True, timeout=PLAY_TIMEOUT, check=False)
        assert played.returncode == 0, played.stderr
        assert f'played {SAMPLES} messages' in played.stderr, played.stderr
        assert 'every one acknowledged' in played.stderr, played.stderr
        out = identifier.stop(signal.SIGINT, timeout=STOP_TIMEOUT)
    assert out.returncode == 0, out.stderr
    info = json.loads(stats.read_text())
    assert info['processed'] == info['predicted'] == SAMPLES, (info, out.stderr[-3000:])
    assert not info['skipped'], info


def test_the_player_does_not_claim_what_was_not_acknowledged(listener: Any) -> None:
    """A keep-all subscriber that never takes a message stops acknowledging once its
    queue is full; a player whose history holds the whole bag (no window to wait for)
    publishes everything, waits for the acknowledgements in vain, and says so."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    listener.subscribe(JointState, '/joint_states', QoSProfile(
        history=HistoryPolicy.KEEP_ALL, depth=1, reliability=ReliabilityPolicy.RELIABLE))
    with NodeProcess(PLAYER, ['-p', f'bag:={BAG}', '-p', 'rate:=0.0',
                              '-p', "topics:=['/joint_states']",
                              '-p', f'qos_depth:={2 * SAMPLES}',
                              '-p', 'wait_timeout:=30.0']) as player:
        out = player.wait(timeout=PLAY_TIMEOUT)  # the listener is never spun meanwhile
    assert out.returncode == 1, out.stderr
    assert f'played {SAMPLES} messages' in out.stderr, out.stderr
    assert 'every one acknowledged' not in out.stderr, out.stderr
    assert 'not every message was acknowledged' in out.stderr, out.stderr
