"""The kernel learners (``kernel``, ``gp``) as methods of the identifier node, beside a
network: every sample predicted and published, the learner process's final state saved
with exactly the learnt samples (never the held-out ones)."""
from __future__ import annotations

import json
import signal
from pathlib import Path

import numpy as np
import pytest

from scara_ident_ros.estimator import load_model
from scara_ident_ros.learners import SparseSpectrumGP

import rostest  # test/nodes/rostest.py
from test_identifier import (IDENTIFIER, LAG, PERIOD_NS, STREAM_TIMEOUT, T0_NS, Feed,
                             sample_msg, simulated, stamps)

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_kernel_beside_a_network_predicts_publishes_and_saves(
        tmp_path: Path, listener: rostest.Listener) -> None:
    n = 1500
    record = simulated(n)
    msgs = [sample_msg(record, i, T0_NS + i * PERIOD_NS) for i in range(n)]
    ffs, kernel = Feed(listener, namespace='/ffs'), Feed(listener, namespace='/kernel')
    args = ['-p', 'methods:=[ffs,kernel]', '-p', f'stats_file:={tmp_path}/{{method}}.json',
            '-p', f'save_path:={tmp_path}/{{method}}.npz', '-p', 'learner_warmup:=400',
            '-p', 'kernel_features:=100', '-p', 'validation_block:=100']
    with rostest.NodeProcess(IDENTIFIER, args) as node:
        kernel.wait_for(node)
        ffs.wait_for(node)
        kernel.send(msgs, n - LAG)
        assert listener.spin_until(lambda: len(ffs.torques) >= n - LAG, STREAM_TIMEOUT)
        assert not node.exited(), node.stderr_so_far()
        out = node.stop(signal.SIGINT)
        assert out.returncode == 0 and 'Traceback' not in out.stderr, out.stderr
    kernel.receive_rest(n)
    ffs.receive_rest(n)
    info = json.loads((tmp_path / 'kernel.json').read_text())
    assert info['method'] == 'kernel' and info['predicted'] == n, info
    assert info['held_out'] > 0 and info['learnt'] + info['held_out'] == n, info
    assert stamps(kernel.torques) == [T0_NS + i * PERIOD_NS for i in range(n)]
    efforts = np.array([m.effort for m in kernel.torques])
    assert np.isfinite(efforts).all() and efforts.shape == (n, 4)
    saved = load_model(tmp_path / 'kernel.npz')
    assert isinstance(saved, SparseSpectrumGP) and saved.method == 'kernel'
    # the learner process took every learnt sample and no held-out one
    assert saved.n_samples_ == info['learnt']
    assert list(saved.joint_names or ()) == ['joint1', 'joint2', 'joint3', 'joint4']
