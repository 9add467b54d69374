"""The body the simulator nodes share: pacing, publishing, QoS, start-up wait, diagnostics.

A simulator node (``scara_sim``, ``robot_sim``) builds a
:class:`~scara_ident_ros.sim.simulator.Simulator` from its own parameters (which robot) and
leaves the rest to :class:`SimulatorNode`: it paces the simulator against absolute deadlines
and converts each sample to a ``sensor_msgs/JointState``: ``position`` (rad, m),
``velocity`` (rad/s, m/s) and ``effort`` (N·m, N) = the torque/force actually applied,
``header.stamp`` = simulated time. Once a second it reports on ``/diagnostics`` (hardware_id
the node's name) its rate and its late samples
(:func:`~scara_ident_ros.nodes.health.simulator_health`). The parameters every
simulator node has are :data:`SIM_PARAMETERS`.

With ``trajectory:=external`` the robot is an arm under a trajectory controller: it follows
the ``trajectory_msgs/JointTrajectory`` commands on
``/joint_trajectory_controller/joint_trajectory`` (remappable) as ``joint_trajectory_controller``
would (:class:`~scara_ident_ros.sim.trajectory_follower.TrajectoryFollower`), with the same
computed torque + PD, holding the middle of each joint's range until the first command.

``~/external_effort`` (``sensor_msgs/JointState``: ``name`` and ``effort``, N·m or N) applies
an external effort to the named joints (the others 0) from the next sample until the next
message (an empty one ends it): a contact, a load the joints must supply, which accelerates
the arm and to which the controller reacts, while ``effort`` stays the actuators' (see
:meth:`~scara_ident_ros.sim.simulator.Simulator.apply_external`).
"""
from __future__ import annotations

import json
import math
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.duration import Duration
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from scara_ident_ros.nodes.health import Deltas, Health, simulator_health
from scara_ident_ros.nodes.diagnostics import Diagnostics
from scara_ident_ros.nodes.messages import NS_PER_S, joint_state, ns_to_stamp
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.runtime import POLL_PERIOD
from scara_ident_ros.nodes.pacer import DeadlinePacer
from scara_ident_ros.nodes.realtime import REALTIME_PRIORITY
from scara_ident_ros.nodes.subscribers import WAIT_FOR_NODES, subscribers_heard
from scara_ident_ros.sim import (SEQUENCE, TRAJECTORIES, FourierTrajectory, SequenceTrajectory,
                                 SimConfig, Simulator, make_trajectory)
from scara_ident_ros.sim.trajectory_follower import TrajectoryFollower
from scara_ident_ros.topics import CLOCK, EXTERNAL_EFFORT, JOINT_STATES, JOINT_TRAJECTORY

__all__ = ['SimulatorNode', 'SIM_PARAMETERS', 'HISTORY', 'EXTERNAL', 'history_depth',
           'fixed_at_start', 'sim_config', 'desired_motion']

#: s of samples the publisher keeps for reliable subscribers (depth = rate_hz × this): a
#: subscriber cut off for up to 5 s gets every sample back, with as much again for the
#: unacknowledged ones and the reconnection; a longer partition loses the oldest samples,
#: which the recorder and the identifiers count as lost.
HISTORY = 10.0
STATS_PERIOD = 10.0  # seconds between statistics log lines
SPIN_PERIOD = 0.01  # seconds between two executor.spin_once calls while publishing
ACK_TIMEOUT = 5.0  # seconds the last samples may take to be acknowledged at shutdown
EXTERNAL = 'external'  # trajectory: follow JointTrajectory commands, as a controller would

#: The parameters of every simulator node, after its robot's own.
SIM_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('rate_hz', 1000.0, 'Sample rate; simulated time advances 1/rate_hz per sample',
              'Hz', min=1.0, max=100_000.0),
    ParamSpec('jitter', 0.0, 'Standard deviation of each stamp around its nominal time '
              'k/rate_hz, as a ros2_control loop wakes up (seeded, clipped to 0.45/rate_hz; '
              'the state is simulated at the jittered stamp, published at the nominal time); '
              '0: exact stamps', 's', min=0.0, max=0.5),
    ParamSpec('real_time_factor', 1.0, 'Simulated seconds per wall-clock second; '
              '0 runs as fast as possible', min=0.0, max=1000.0),
    ParamSpec('duration', 0.0, 'Simulated time after which the node stops; 0 runs forever',
              's', min=0.0),
    ParamSpec('trajectory', SEQUENCE, 'Excitation: a preset finite Fourier series (gentle, '
              'standard, aggressive) repeated, or sequence, a new random standard-like one '
              'every 5 s joined smoothly; external: follow the JointTrajectory commands on '
              f'{JOINT_TRAJECTORY} as a trajectory controller',
              choices=(*TRAJECTORIES, EXTERNAL)),
    ParamSpec('seed', 0, 'Seed of the excitation and of the measurement noise', min=0),
    ParamSpec('substeps', 4, 'RK4 integration steps per sample', min=1, max=100),
    ParamSpec('position_noise', 0.0, 'Std of measurement noise on q (rad or m)', min=0.0),
    ParamSpec('velocity_noise', 0.0, 'Std of measurement noise on qd (rad/s or m/s)', min=0.0),
    ParamSpec('effort_noise', 0.0, 'Std of measurement noise on effort (N·m or N)', min=0.0),
    ParamSpec('disturbance', 0.0, 'Amplitude of the disturbance torque T_d of eq. 6, as a '
              'fraction of each joint effort limit; 0 is off', min=0.0, max=1.0),
    ParamSpec('stamp_origin', 'wall', "Simulated time zero: 'wall' = the wall-clock time at "
              "start (stamps comparable with other nodes' clocks), 'zero' = 0",
              choices=('wall', 'zero')),
    ParamSpec('publish_clock', False, 'Also publish the simulated time on /clock'),
    ParamSpec('history', HISTORY, 'Samples kept for reliable subscribers, as time: the '
              'publisher keeps the last rate_hz x history samples, so a subscriber cut off '
              'for up to about history/2 (a network partition) gets every sample back',
              's', min=0.01, max=60.0),
    ParamSpec('wait_for_subscribers', 0, 'Before the first sample, wait until this many '
              'subscribers are matched on joint_states (0: start at once)', min=0),
    WAIT_FOR_NODES,
    ParamSpec('wait_timeout', 30.0, 'Longest wait for those subscribers', 's', min=0.0),
    ParamSpec('stats_file', '', 'Write the final counters here as JSON on shutdown; empty: '
              'never'),
    ParamSpec('frame_id', '', 'header.frame_id of the published JointState'),
    REALTIME_PRIORITY,
)


def fixed_at_start(specs: tuple[ParamSpec, ...]) -> tuple[ParamSpec, ...]:
    """The specs, each saying why it is fixed at start (ros2 param describe shows it)."""
    return tuple(replace(spec, fixed=spec.fixed or 'the simulator and its pacer are built '
                         'once') for spec in specs)


def history_depth(rate_hz: float, history: float) -> int:
    """QoS history depth (messages) that keeps ``history`` seconds at ``rate_hz`` (Hz)."""
    return max(1, math.ceil(round(rate_hz * history, 6)))  # 1000 x 0.3: 300, not 301


def sim_config(settings: dict[str, Any], n_joints: int) -> SimConfig:
    """The :class:`SimConfig` of the :data:`SIM_PARAMETERS` values, for n_joints joints."""
    s = settings
    return SimConfig(
        dt=round(NS_PER_S / s['rate_hz']) / NS_PER_S, substeps=s['substeps'], seed=s['seed'],
        position_noise=s['position_noise'], velocity_noise=s['velocity_noise'],
        effort_noise=s['effort_noise'], disturbance=s['disturbance'], jitter=s['jitter'],
        n_joints=n_joints)


def desired_motion(settings: dict[str, Any], robot: Any, names: tuple[str, ...]
                   ) -> FourierTrajectory | SequenceTrajectory | TrajectoryFollower:
    """The ``trajectory`` of the settings for ``robot`` (ScaraParams or PinocchioRobot):
    an excitation, or with ``external`` a follower of the commands to joints ``names`` (the
    names on the wire), holding the middle of each range until the first."""
    if settings['trajectory'] == EXTERNAL:
        return TrajectoryFollower(names, robot.position_centre)
    return make_trajectory(settings['trajectory'], robot, seed=settings['seed'])


class SimulatorNode(Node):
    """Publish a simulator's joint states against absolute deadlines.

    Parameters
    ----------
    name : str
        Node name, also the hardware_id of its diagnostics.
    parameters : tuple of ParamSpec
        Every parameter of the node (its robot's, then :data:`SIM_PARAMETERS`).

    Notes
    -----
    A subclass implements :meth:`build`, which returns the simulator, the joint names on
    the wire and what is simulated (for the start-up log line); it raises
    :class:`~scara_ident_ros.errors.ConfigError` for bad parameters.
    """

    def __init__(self, name: str, parameters: tuple[ParamSpec, ...]) -> None:
        super().__init__(name)
        self.settings = declare_parameters(self, parameters)
        s = self.settings
        self.period_ns = round(NS_PER_S / s['rate_hz'])
        self.simulator, names, what = self.build(s)
        self.origin_ns = 0  # set when the first sample is published (stamp_origin wall)
        self.limit = (round(s['duration'] * NS_PER_S / self.period_ns)
                      if s['duration'] > 0 else None)
        qos = QoSProfile(depth=history_depth(s['rate_hz'], s['history']),
                         reliability=ReliabilityPolicy.RELIABLE)
        self.publisher = self.create_publisher(JointState, JOINT_STATES, qos)
        self.clock_publisher = (self.create_publisher(Clock, CLOCK, 10)
                                if s['publish_clock'] else None)
        desired = self.simulator.trajectory
        self.follower = desired if isinstance(desired, TrajectoryFollower) else None
        if self.follower is not None:
            self.create_subscription(JointTrajectory, JOINT_TRAJECTORY, self.on_command,
                                     QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self.msg = joint_state(0, names, frame_id=s['frame_id'])
        self.joint_index = {name: j for j, name in enumerate(names)}
        self.create_subscription(JointState, EXTERNAL_EFFORT, self.on_external_effort, 10)
        self.published = 0
        self.pacer = DeadlinePacer(self.period_ns, real_time_factor=s['real_time_factor'])
        self.waiting = True  # for subscribers: nothing published yet on purpose
        self.deltas = Deltas()
        self.diagnostics = Diagnostics(self, 'simulation', self.health, hardware_id=name)
        self.get_logger().info(
            f'simulating {what} at {s["rate_hz"]:g} Hz, trajectory {s["trajectory"]!r}, '
            f'seed {s["seed"]}, publishing {self.publisher.topic_name} (reliable, '
            f'{qos.depth} samples of history: {s["history"]:g} s)')

    def build(self, settings: dict[str, Any]) -> tuple[Simulator, tuple[str, ...], str]:
        """The simulator, the joint names on the wire and what is simulated (for the log)."""
        raise NotImplementedError

    def on_command(self, msg: JointTrajectory) -> None:
        """Give a trajectory command to the follower, in simulated time (trajectory external)."""
        assert self.follower is not None
        if self.waiting:
            self.get_logger().warning('trajectory command before the first sample: ignored')
            return
        stamp_ns = msg.header.stamp.sec * NS_PER_S + msg.header.stamp.nanosec
        points = msg.points
        reason = self.follower.command(
            list(msg.joint_names), stamp_ns - self.origin_ns if stamp_ns else None,
            [p.time_from_start.sec * NS_PER_S + p.time_from_start.nanosec for p in points],
            [p.positions for p in points],
            [p.velocities for p in points] if all(len(p.velocities) for p in points) else None,
            ([p.accelerations for p in points] if all(len(p.accelerations) for p in points)
             else None), self.simulator.stamp_ns)
        if reason is not None:
            self.get_logger().warning(f'trajectory command refused: {reason}')

    def publish_next(self) -> None:
        """Advance the simulator one sample and publish it."""
        stamp_ns, q, qd, _, effort = self.simulator.advance()
        stamp_ns += self.origin_ns
        msg = self.msg  # reused: publish() serialises it before returning
        sec, nanosec = divmod(stamp_ns, NS_PER_S)
        msg.header.stamp.sec = sec
        msg.header.stamp.nanosec = nanosec
        msg.position = q
        msg.velocity = qd
        msg.effort = effort
        self.publisher.publish(msg)
        if self.clock_publisher is not None:
            self.clock_publisher.publish(Clock(clock=ns_to_stamp(stamp_ns)))

    def on_external_effort(self, msg: JointState) -> None:
        """``~/external_effort``: apply these efforts to the named joints (the others 0)
        from the next sample on, until the next message; refuse unknown joints."""
        index = self.joint_index
        unknown = [name for name in msg.name if name not in index]
        if unknown or len(msg.effort) != len(msg.name):
            self.get_logger().warning(
                f'external_effort ignored: it must name joints of {list(index)} with one '
                f'effort each, got names {list(msg.name)} and {len(msg.effort)} efforts')
            return
        effort = np.zeros(len(index))
        for name, value in zip(msg.name, msg.effort):
            effort[index[name]] = value
        try:
            self.simulator.apply_external(effort)
        except ValueError as exc:
            self.get_logger().warning(f'external_effort ignored: {exc}')

    def loop(self, executor: Executor, stop: threading.Event) -> None:
        """Publish on absolute deadlines until ``stop`` is set or the duration is reached."""
        if not self.wait_for_subscribers(executor, stop):
            return
        self.waiting = False
        # Time zero is now, not at start-up: waiting for subscribers must not put the
        # wall-clock stamps behind the wall clock.
        if self.settings['stamp_origin'] == 'wall':
            self.origin_ns = time.time_ns() // 1_000_000 * 1_000_000
        self.pacer.restart()
        next_stats = time.monotonic() + STATS_PERIOD
        next_spin = 0.0
        while not stop.is_set():
            due = self.pacer.wait(POLL_PERIOD)
            if self.limit is not None:
                due = min(due, self.limit - self.published)
            for _ in range(due):
                self.publish_next()
            self.published += due
            if self.limit is not None and self.published >= self.limit:
                break
            now = time.monotonic()
            if now >= next_spin:  # services (parameters) only: no need to spin every sample
                executor.spin_once(timeout_sec=0)
                next_spin = now + SPIN_PERIOD
            if now >= next_stats:
                next_stats += STATS_PERIOD
                self.log_stats()

    def wait_for_subscribers(self, executor: Executor, stop: threading.Event) -> bool:
        """Wait for ``wait_for_subscribers`` matched subscribers, those of ``wait_for_nodes``
        among them; False if stopped meanwhile."""
        wanted, names = self.settings['wait_for_subscribers'], self.settings['wait_for_nodes']
        deadline = time.monotonic() + self.settings['wait_timeout']
        while not subscribers_heard(self, self.publisher, wanted, names):
            if stop.is_set():
                return False
            if time.monotonic() > deadline:
                self.get_logger().warning(
                    f'only {self.publisher.get_subscription_count()} of {wanted} subscribers '
                    f'{"(" + ", ".join(names) + ") " if names else ""}'
                    f'after {self.settings["wait_timeout"]:g} s; starting anyway')
                break
            executor.spin_once(timeout_sec=0.05)
        return True

    def health(self, period_s: float) -> Health:
        """The simulator's health over the last ``period_s`` s, for ``/diagnostics``."""
        recent = self.deltas(published=self.published, late=self.pacer.late)
        s = self.settings
        return simulator_health(
            period_s=period_s, nominal_hz=s['rate_hz'] * s['real_time_factor'],
            published=self.published, late=self.pacer.late,
            recent_published=int(recent['published']), recent_late=int(recent['late']),
            waiting=self.waiting)

    def log_stats(self) -> None:
        """Log how many samples were published and how many were late."""
        self.get_logger().info(
            f'published {self.published} samples '
            f'({self.published * self.period_ns / NS_PER_S:.3f} s simulated), '
            f'{self.pacer.late} late by more than one period')

    def close(self) -> None:
        """On shutdown: let subscribers acknowledge the tail, then final statistics."""
        self.publisher.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT))
        self.log_stats()
        if self.settings['stats_file']:
            Path(self.settings['stats_file']).write_text(json.dumps(
                {'published': self.published, 'late': self.pacer.late,
                 'first_stamp_ns': self.origin_ns if self.published else None,
                 'period_ns': self.period_ns}, indent=1))

