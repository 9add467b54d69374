"""The lm trainer beside the stream: a learner process that the message path never waits for."""
from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator

import numpy as np
import pytest
from numpy.typing import NDArray

from scara_ident_ros.identification import make_trainer
from scara_ident_ros.identification.background_lm import BACKLOG, BackgroundLM
from scara_ident_ros.identification.learner_settings import LearnerSettings
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn import FeedForwardNet
from robot_scaling import robot_scaling  # test/robot_scaling.py

N_JOINTS = 2
WAIT = 30.0  # s: the longest a test waits for the learner (a loaded CI machine)


def network(seed: int = 0) -> FeedForwardNet:
    net = make_network('ffs', N_JOINTS, n_hidden=10, seed=seed)
    net.set_scaling(-np.ones(3 * N_JOINTS), np.ones(3 * N_JOINTS),
                    -2 * np.ones(N_JOINTS), 2 * np.ones(N_JOINTS))
    return net


def data(n: int, seed: int = 0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A smooth target the network can learn: y from x of shape (n, 6)."""
    X = np.random.default_rng(seed).uniform(-1.0, 1.0, (n, 3 * N_JOINTS))
    return X, np.stack([np.sin(2 * X[:, 0]) + X[:, 3], X[:, 1] * X[:, 2]], axis=1)


@pytest.fixture
def trainer() -> Iterator[BackgroundLM]:
    made = BackgroundLM(network(), LearnerSettings(reservoir_size=500, lm_interval=50, lm_steps=2))
    assert made.wait_ready(WAIT)
    yield made
    made.close()


def stream(trainer: BackgroundLM, X: NDArray[np.float64], Y: NDArray[np.float64]) -> None:
    """Feed the samples as a stream does, a few at a time (the learner updates when at
    least ``interval`` new samples have come, so a burst would give it one update)."""
    for k, (x, y) in enumerate(zip(X, Y, strict=True)):
        assert trainer.learn(x, y).shape == (N_JOINTS,)
        if k % 20 == 19:
            time.sleep(0.002)


def wait_until(condition, trainer: BackgroundLM) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        trainer.poll()
        if condition():
            return True
        time.sleep(0.01)
    return False


def test_it_learns_in_the_background_and_hands_over_its_last_weights(
        trainer: BackgroundLM) -> None:
    X, Y = data(3000)
    model = trainer.model
    before = float(np.mean((model.predict(X) - Y) ** 2))
    stream(trainer, X, Y)
    assert wait_until(lambda: trainer.updates >= 5, trainer), trainer.updates
    assert trainer.sent == len(X) and trainer.dropped == 0
    trainer.close()
    assert not trainer.alive
    after = float(np.mean((model.predict(X) - Y) ** 2))
    assert after < 0.2 * before, (before, after)
    assert trainer.steps_taken >= 2 * trainer.updates


def test_the_message_path_never_waits_for_a_stopped_learner(trainer: BackgroundLM) -> None:
    """With the learner frozen (SIGSTOP: as if the CPU were taken from it), every sample is
    still predicted at once; what the pipe cannot take waits in the backlog, and beyond
    that is dropped and counted, never waited for."""
    X, Y = data(200)
    for x, y in zip(X, Y, strict=True):
        trainer.learn(x, y)
    pid = trainer._process.pid
    os.kill(pid, signal.SIGSTOP)
    try:
        rows = BACKLOG * trainer._batch.shape[0] + 50_000  # more than pipe and backlog hold
        X2, Y2 = data(rows, seed=1)
        start = time.monotonic()
        for x, y in zip(X2, Y2, strict=True):
            assert np.isfinite(trainer.learn(x, y)).all()
        took = time.monotonic() - start
        assert trainer.dropped > 0  # the backlog overflowed: samples were let go, not waited for
        assert trainer.sent == 200 + rows
    finally:
        os.kill(pid, signal.SIGCONT)
    assert took < rows * 1e-3  # faster than the samples' own 1 kHz, however loaded
    assert wait_until(lambda: trainer.updates >= 1, trainer)


def test_it_says_how_long_a_due_update_has_waited(trainer: BackgroundLM) -> None:
    """An update is due once ``interval`` samples have come since the last finished one;
    a frozen learner leaves it waiting (the diagnostics warn), a running one catches up."""
    assert trainer.overdue() is None  # nothing sent yet
    X, Y = data(400)
    pid = trainer._process.pid
    os.kill(pid, signal.SIGSTOP)
    try:
        stream(trainer, X[:49], Y[:49])
        assert trainer.overdue() is None  # one sample short of the interval (50)
        stream(trainer, X[49:], Y[49:])
        time.sleep(0.3)
        trainer.poll()
        waited = trainer.overdue()
        assert waited is not None and waited >= 0.3
    finally:
        os.kill(pid, signal.SIGCONT)
    assert wait_until(lambda: trainer.overdue() is None, trainer)


def test_an_update_at_a_minimum_counts_as_finished(trainer: BackgroundLM) -> None:
    """Samples the network already predicts exactly: no LM step lowers the error, the
    weights stay, and the learner still answers, so no update stays due."""
    X, _ = data(300)
    Y = trainer.model.predict(X)
    stream(trainer, X, Y)
    assert wait_until(lambda: trainer.overdue() is None, trainer)
    trainer.close()
    assert trainer.updates == 0


@pytest.mark.parametrize('nice', [0, 7])
def test_the_learner_runs_at_the_niceness_it_is_given(nice: int) -> None:
    """The niceness adds to the caller's (``lm_nice``): the learner gives way to the stream."""
    made = BackgroundLM(network(), LearnerSettings(lm_nice=nice))
    try:
        assert made.wait_ready(WAIT)
        own = os.getpriority(os.PRIO_PROCESS, 0)
        assert os.getpriority(os.PRIO_PROCESS, made._process.pid) == min(own + nice, 19)
    finally:
        made.close()


def test_weights_are_swapped_whole(trainer: BackgroundLM) -> None:
    """Under a stream of updates, each prediction is made with one complete set of weights
    the learner sent (or the first): never a mix of two."""
    model = trainer.model
    sent: list[NDArray[np.float64]] = [model.get_theta()]
    set_theta = model.set_theta

    def record(theta: NDArray[np.float64]) -> None:
        sent.append(np.array(theta, copy=True))
        set_theta(theta)

    model.set_theta = record  # type: ignore[method-assign]
    probe = network()
    X, Y = data(6000, seed=2)
    for k, (x, y) in enumerate(zip(X, Y, strict=True)):
        if k % 20 == 19:
            time.sleep(0.002)
        weights = model.get_theta()
        assert np.array_equal(weights, sent[-1])  # the last complete set received
        predicted = trainer.learn(x, y)
        probe.set_theta(weights)
        assert np.array_equal(predicted, probe.predict(x))  # made with exactly those
    assert wait_until(lambda: len(sent) > 3, trainer)


def test_the_schedule_changes_while_it_runs(trainer: BackgroundLM) -> None:
    trainer.set_schedule(lm_interval=10**9, lm_steps=1)  # no more updates: never enough samples
    X, Y = data(1000, seed=3)
    for x, y in zip(X, Y, strict=True):
        trainer.learn(x, y)
    time.sleep(1.0)
    trainer.poll()
    assert trainer.updates == 0


def test_make_trainer_builds_it_for_the_node() -> None:
    made = make_trainer('lm', network(), reservoir_size=100, lm_interval=10, background=True)
    try:
        assert isinstance(made, BackgroundLM) and made.alive
    finally:
        made.close()
    assert not made.alive


def test_a_7_joint_arm_stream_keeps_up_with_the_learner_beside_it() -> None:
    """A Panda's stream from the simulator through the identifier core with the background
    lm trainer at its defaults: every sample is predicted and handed to the learner (none
    dropped), the learner updates the weights, and the message path takes less CPU than the
    stream's own duration (a loose bound: 1 ms a sample at 1 kHz)."""
    from scara_ident_ros.paper.datasets import simulate_record
    from scara_ident_ros.identification import Holdout, OnlineIdentifier, make_differentiator
    from scara_ident_ros.sim.example_robots import example_robot
    from scara_ident_ros.sim.pinocchio_robot import PinocchioRobot

    arm = example_robot('panda')
    robot = PinocchioRobot.from_urdf(arm.urdf, joints=arm.joints)
    n = len(robot.joint_names)
    assert n == 7
    record = simulate_record(robot, seconds=4.0, seed=3, preset='sequence')
    net = make_network('ffs', n, seed=0, friction_steps=True)
    net.set_scaling(*robot_scaling(robot))
    trainer = make_trainer('lm', net, background=True)
    assert isinstance(trainer, BackgroundLM) and trainer.wait_ready(WAIT)
    ident = OnlineIdentifier(net, joint_names=robot.joint_names,
                             differentiator=make_differentiator('centred', window=21),
                             trainer=trainer, holdout=Holdout(3 * n, n, seed=0))
    try:
        began = time.process_time()
        for k in range(len(record)):
            ident.process(int(record.stamp_ns[k]), robot.joint_names, record.q[k],
                          record.qd[k], record.effort[k])
            if k % 200 == 199:
                trainer.poll()
                time.sleep(0.01)  # the stream's pace, roughly: the learner gets the CPU
        cpu = time.process_time() - began
        counts = ident.counts
        assert counts.processed == len(record)
        assert counts.predicted == counts.processed - counts.pending
        assert sum(counts.skipped.values()) == 0
        assert trainer.sent == counts.learnt > 0 and trainer.dropped == 0
        assert wait_until(lambda: trainer.updates >= 1, trainer), trainer.updates
        assert cpu < 4.0, cpu  # the stream's 4 s
    finally:
        trainer.close()


def test_the_identifier_takes_a_finished_update_while_it_learns_nothing() -> None:
    """Polled every sample: an update that finishes after the last learnt sample is taken
    at the next sample, though that one is not learnt (no effort); with ``learn`` False the
    model stays as it is."""
    from scara_ident_ros.identification.input_stage import Input
    from scara_ident_ros.identification.online_identifier import OnlineIdentifier

    made = BackgroundLM(network(), LearnerSettings(reservoir_size=500, lm_interval=100,
                                                   lm_steps=2))
    try:
        assert made.wait_ready(WAIT)
        ident = OnlineIdentifier(made.model, trainer=made, learner=made)
        # whole batches, the last one bringing the learner to its interval: its only update
        # starts with the last learnt sample, whose take polls microseconds after sending,
        # so the update finishes after it (with 200 samples, the update began at sample 138
        # and could be taken before sample 200, as it was once on a loaded CI machine)
        batch = made._batch.shape[0]
        n = batch * -(-100 // batch)
        X, Y = data(n)
        for k, (x, y) in enumerate(zip(X, Y, strict=True)):
            ident.take(k, None, [Input(k, x, y)])
        before = made.updates
        # the learner's answers are in the pipe, not yet taken (nothing was learnt since)
        assert made._from_learner.poll(WAIT)
        ident.learn = False  # frozen: the answer waits
        for k in range(20):
            ident.take(1000 + k, None, [Input(1000 + k, X[k], Y[k])])
        assert made.updates == before
        ident.learn = True
        deadline = time.monotonic() + WAIT
        while made.updates == before and time.monotonic() < deadline:
            ident.take(2000, None, [Input(2000, X[0], None)])  # predicted, not learnt
            time.sleep(0.01)
        assert made.updates > before and ident.counts.learnt == n
    finally:
        made.close()
