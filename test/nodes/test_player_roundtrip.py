"""Record -> play -> record again gives the same messages: topics, bytes and order.

A 1 kHz publisher process (``test_recorder.py publish``) is recorded into bag A; bag A
is played by the player while a second recorder records bag B. The two bags must hold
the same topics with byte-identical messages in the same order. (Across topics the
publisher keeps half a period, 0.5 ms, between messages, so that the order of
reception is the order of publication.)
"""
from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros


HERE = Path(__file__).resolve().parent

RECORDER = 'scara_ident_ros.nodes.recorder'
PLAYER = 'scara_ident_ros.nodes.player'

def read(bag: Path) -> list[tuple[str, int, bytes]]:
    from scara_ident_ros.bag import open_bag

    with open_bag(bag) as source:
        return [(m.topic, m.log_time_ns, m.data) for m in source.messages()]


def test_record_play_record_gives_the_same_messages(tmp_path: Path, domain: int) -> None:
    from rostest import NodeProcess

    first, second = tmp_path / 'first', tmp_path / 'second'
    record_args = ['-p', 'discovery_period:=0.2']
    with NodeProcess(RECORDER, ['-p', f'output:={first}', *record_args]) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        publisher = subprocess.run(
            [sys.executable, str(HERE / 'test_recorder.py'), 'publish', '--count', '1500',
             '--mse-every', '10'], capture_output=True, text=True, timeout=120, check=False)
        assert publisher.returncode == 0, publisher.stdout + publisher.stderr
        assert recorder.stop(signal.SIGINT).returncode == 0

    with NodeProcess(RECORDER, ['-p', f'output:={second}', *record_args]) as recorder:
        recorder.wait_for_stderr('recording', timeout=30)
        with NodeProcess(PLAYER, ['-p', f'bag:={first}',
                                  '-p', 'wait_timeout:=30.0']) as player:
            output = player.wait(timeout=120)
        assert output.returncode == 0, output.stderr
        assert recorder.stop(signal.SIGINT).returncode == 0

    original, replayed = read(first), read(second)
    assert len(original) == 1650
    assert {t for t, _, _ in replayed} == {t for t, _, _ in original} == {
        '/joint_states', '/ffmw/identification_mse'}
    assert [(t, data) for t, _, data in replayed] == [(t, data) for t, _, data in original]
    # and the replay kept the timing: same spacing within a few milliseconds
    span = original[-1][1] - original[0][1]
    replayed_span = replayed[-1][1] - replayed[0][1]
    assert abs(replayed_span - span) < 0.05 * span
