"""``scara_sim``: the simulated SCARA, publishing ``/joint_states`` in real time.

The physics (Lagrangian model, excitation, computed-torque controller, RK4) live in
:mod:`scara_ident_ros.sim`; this node only paces the simulator against absolute
deadlines and converts each sample to a ``sensor_msgs/JointState``:
``position`` (rad, m), ``velocity`` (rad/s, m/s) and ``effort`` (N·m, N) = the
torque/force actually applied, ``header.stamp`` = simulated time. Once a second it
reports on ``/diagnostics`` (hardware_id ``scara_sim``) its rate and its late samples
(:func:`~scara_ident_ros.identification.health.simulator_health`).

With ``trajectory:=external`` it is the arm under a trajectory controller: it follows the
``trajectory_msgs/JointTrajectory`` commands on ``/joint_trajectory_controller/joint_trajectory``
(remappable) as ``joint_trajectory_controller`` would
(:class:`~scara_ident_ros.sim.trajectory_follower.TrajectoryFollower`), with the same
computed torque + PD, holding the middle of each joint's range until the first command.
"""
from __future__ import annotations

import json
import math
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path

from rclpy.duration import Duration
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from scara_ident_ros.dynamics import ParamError, ScaraParams
from scara_ident_ros.identification.health import Deltas, Health, simulator_health
from scara_ident_ros.nodes.diagnostics import Diagnostics
from scara_ident_ros.nodes.messages import NS_PER_S, joint_state, ns_to_stamp
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.runtime import POLL_PERIOD, ConfigError, run_node
from scara_ident_ros.pacer import DeadlinePacer
from scara_ident_ros.resources import config_path
from scara_ident_ros.sim import SEQUENCE, TRAJECTORIES, SimConfig, Simulator, make_trajectory
from scara_ident_ros.sim.trajectory_follower import TrajectoryFollower
from scara_ident_ros.topics import CLOCK, JOINT_STATES, JOINT_TRAJECTORY

__all__ = ['ScaraSimNode', 'main', 'history_depth', 'HISTORY']

#: s of samples the publisher keeps for reliable subscribers (history depth = rate_hz x this):
#: a subscriber cut off for up to 5 s (a network partition, a stalled process) gets every
#: sample once it is back, with as much again for the samples not yet acknowledged when the
#: link went down and for the reconnection. A partition longer than the history loses the
#: oldest samples (as many as it outlasts it: 8 s with 5 s of history lost 3,017 of 12,000;
#: 2 s with 1 s lost 1,014); the recorder and the identifiers count them as lost.
HISTORY = 10.0
STATS_PERIOD = 10.0  # seconds between statistics log lines
SPIN_PERIOD = 0.01  # seconds between two executor.spin_once calls while publishing
ACK_TIMEOUT = 5.0  # seconds the last samples may take to be acknowledged at shutdown
EXTERNAL = 'external'  # trajectory: follow JointTrajectory commands, as a controller would

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('robot_config', '', 'YAML file of the robot parameters; empty: the installed '
              'config/scara.yaml'),
    ParamSpec('joint_names', [], 'Joint names on the wire, in the order joint1..joint4; '
              'empty: the joint_names of the robot file', items=str),
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
              f'{JOINT_TRAJECTORY} as a trajectory controller', choices=(*TRAJECTORIES, EXTERNAL)),
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
    ParamSpec('wait_timeout', 30.0, 'Longest wait for those subscribers', 's', min=0.0),
    ParamSpec('stats_file', '', 'Write the final counters here as JSON on shutdown; empty: '
              'never'),
    ParamSpec('frame_id', '', 'header.frame_id of the published JointState'),
)
# None is settable while running (ros2 param describe says why).
PARAMETERS = tuple(replace(spec, fixed=spec.fixed or 'the simulator and its pacer are built '
                           'once') for spec in PARAMETERS)


def history_depth(rate_hz: float, history: float) -> int:
    """QoS history depth (messages) that keeps ``history`` seconds at ``rate_hz`` (Hz)."""
    return max(1, math.ceil(round(rate_hz * history, 6)))  # 1000 x 0.3: 300, not 301


class ScaraSimNode(Node):
    """Publish the simulated SCARA's joint states against absolute deadlines."""

    def __init__(self) -> None:
        super().__init__('scara_sim')
        self.settings = declare_parameters(self, PARAMETERS)
        s = self.settings
        try:
            path = s['robot_config'] or str(config_path('scara.yaml'))
            params = ScaraParams.from_yaml(path)
            names = tuple(s['joint_names']) or params.joint_names
            if len(names) != 4 or len(set(names)) != 4:
                raise ConfigError(f"parameter 'joint_names' must be 4 distinct names, "
                                  f'got {list(names)}')
            self.period_ns = round(NS_PER_S / s['rate_hz'])
            config = SimConfig(
                dt=self.period_ns / NS_PER_S, substeps=s['substeps'], seed=s['seed'],
                position_noise=s['position_noise'], velocity_noise=s['velocity_noise'],
                effort_noise=s['effort_noise'], disturbance=s['disturbance'],
                jitter=s['jitter'])
            self.follower = (TrajectoryFollower(names, params.position_centre)
                             if s['trajectory'] == EXTERNAL else None)
            trajectory = self.follower or make_trajectory(s['trajectory'], params,
                                                          seed=s['seed'])
            self.simulator = Simulator(params, trajectory, config)
        except (ParamError, OSError) as exc:
            raise ConfigError(str(exc)) from None
        self.origin_ns = 0  # set when the first sample is published (stamp_origin wall)
        self.limit = (round(s['duration'] * NS_PER_S / self.period_ns)
                      if s['duration'] > 0 else None)
        qos = QoSProfile(depth=history_depth(s['rate_hz'], s['history']),
                         reliability=ReliabilityPolicy.RELIABLE)
        self.publisher = self.create_publisher(JointState, JOINT_STATES, qos)
        self.clock_publisher = (self.create_publisher(Clock, CLOCK, 10)
                                if s['publish_clock'] else None)
        if self.follower is not None:
            self.create_subscription(JointTrajectory, JOINT_TRAJECTORY, self.on_command,
                                     QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
        self.msg = joint_state(0, names, frame_id=s['frame_id'])
        self.published = 0
        self.pacer = DeadlinePacer(self.period_ns, real_time_factor=s['real_time_factor'])
        self.waiting = True  # for subscribers: nothing published yet on purpose
        self.deltas = Deltas()
        self.diagnostics = Diagnostics(self, 'simulation', self.health, hardware_id='scara_sim')
        self.get_logger().info(
            f'simulating {path} at {s["rate_hz"]:g} Hz, trajectory {s["trajectory"]!r}, '
            f'seed {s["seed"]}, publishing {self.publisher.topic_name} (reliable, '
            f'{qos.depth} samples of history: {s["history"]:g} s)')

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
        """Wait for ``wait_for_subscribers`` matched subscribers; False if stopped meanwhile."""
        wanted = self.settings['wait_for_subscribers']
        deadline = time.monotonic() + self.settings['wait_timeout']
        while self.publisher.get_subscription_count() < wanted:
            if stop.is_set():
                return False
            if time.monotonic() > deadline:
                self.get_logger().warning(
                    f'only {self.publisher.get_subscription_count()} of {wanted} subscribers '
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


def main(args: list[str] | None = None) -> None:
    """Console script ``scara_sim``."""
    sys.exit(run_node('scara_sim', ScaraSimNode, args,
                      description=__doc__ or '', parameters=PARAMETERS))


if __name__ == '__main__':
    main()
