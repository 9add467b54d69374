"""``excitation``: the persistent ``sequence`` excitation on a real arm, through ros2_control.

It reads the arm's joints and limits from its URDF (``urdf_file`` or ``robot_description``;
acceleration limits from ``acceleration_max`` or the robot YAML, as the identifier takes
them), keeps ``position_margin`` of each range clear and ``velocity_scale`` and
``acceleration_scale`` of the limits, waits for ``/joint_states`` and for the controller,
then sends ``joint_trajectory_controller`` the plan of :mod:`scara_ident_ros.excitation`: a
smooth approach from the arm's position at rest to the simulator's sequence excitation (same
seeds and blends), and the sequence. With ``plan: optimized`` the excitation after the
approach is instead the periodic Fourier motion (``harmonics``, ``base_period``) optimised
within the same limits for the physical model of the URDF to predict other motion
(:mod:`~scara_ident_ros.excitation.optimized_excitation`), before the node waits for the
arm (up to two minutes), its links kept apart where ``urdf_file`` has collision geometry.
It sends it as ``trajectory_msgs/JointTrajectory`` chunks on
``/joint_trajectory_controller/joint_trajectory`` (remappable), or as
``control_msgs/action/FollowJointTrajectory`` goals with ``use_action``, every
``chunk_period``: each chunk reaches ``horizon`` ahead and ends in a stop to rest, so an arm
whose chunks stop coming comes to rest by itself.

Ctrl-C (SIGINT, SIGTERM), the ``~/stop`` service (``std_srvs/Trigger``), ``/joint_states``
silent for ``state_timeout`` or the end of ``duration`` send a last chunk that brings the arm
to rest along its path within the acceleration limits; the node exits once the arm is at
rest (0; 1 if ``/joint_states`` was lost). It refuses with one line and exit 2 a URDF without
limits for the joints, joints missing from ``/joint_states``, a start outside the limits, no
``/joint_states`` or no controller within ``wait_timeout``.
"""
from __future__ import annotations

import json
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Duration as DurationMsg
from rclpy.executors import Executor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from scara_ident_ros.dynamics.joint_limits import LimitsError
from scara_ident_ros.errors import ConfigError, ScaraIdentError
from scara_ident_ros.excitation import (Chunk, ExcitationPlan, LoopSettings, load_motion_limits,
                                        make_chunk)
from scara_ident_ros.excitation.optimized_excitation import (DEFAULT_HARMONICS, DEFAULT_PERIOD,
                                                             OptimizedExcitation)
from scara_ident_ros.nodes.messages import NS_PER_S, ns_to_stamp
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.runtime import run_node
from scara_ident_ros.topics import JOINT_STATES, JOINT_TRAJECTORY

__all__ = ['ExcitationNode', 'PARAMETERS', 'main']

NAME = 'excitation'
ACTION = '/joint_trajectory_controller/follow_joint_trajectory'
STOP_LEAD = 0.1  # s from a stop request to the start of the stop: the last chunk's delivery
SPIN_PERIOD = 0.01  # s, longest wait for a callback in the loop
MOTION = LoopSettings()  # the defaults of the parameters that shape the motion
PLANS = ('sequence', 'optimized')
OPTIMIZE_SECONDS = 120.0  # s, the optimisation's time budget

PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec('urdf_file', '', "The arm's URDF file: its joints and limits (or give "
              'robot_description)'),
    ParamSpec('robot_description', '', "The arm's URDF as text (or give urdf_file)"),
    ParamSpec('joint_names', [], 'Joints to excite, in this order; empty: every joint with '
              'limits in the URDF and an acceleration limit', items=str),
    ParamSpec('robot_config', '', 'Robot YAML whose acceleration_max (by joint_names) gives '
              'the acceleration limits URDF has not; empty: the installed config/scara.yaml'),
    ParamSpec('acceleration_max', [], 'Acceleration limit of each joint of joint_names '
              '(rad/s^2 or m/s^2); empty: from robot_config', items=float),
    ParamSpec('position_margin', MOTION.position_margin, "Fraction of each joint's range kept "
              'clear at both ends', min=0.0, max=0.49),
    ParamSpec('velocity_scale', MOTION.velocity_scale, 'Fraction of the velocity limits the '
              'motion keeps to', min=0.01, max=1.0),
    ParamSpec('acceleration_scale', MOTION.acceleration_scale, 'Fraction of the acceleration '
              'limits the motion (and every stop) keeps to', min=0.01, max=1.0),
    ParamSpec('seed', MOTION.seed, 'Seed of the sequence excitation (as scara_sim seed), or '
              "of the optimised plan's start", min=0),
    ParamSpec('plan', 'sequence', 'The excitation after the approach: the random sequence, or '
              'the Fourier motion optimised for identification (least variance of the '
              "efforts the URDF's physical model predicts, well-conditioned regressor)",
              choices=PLANS),
    ParamSpec('harmonics', DEFAULT_HARMONICS, 'plan optimized: harmonics per joint', min=1,
              max=20),
    ParamSpec('base_period', DEFAULT_PERIOD, 'plan optimized: period of the motion', 's',
              min=1.0, max=120.0),
    ParamSpec('duration', 0.0, 'Seconds of excitation after the approach, then a stop; '
              '0: until stopped', 's', min=0.0),
    ParamSpec('point_period', MOTION.point_period, 'Time between two trajectory points', 's',
              min=0.001, max=0.1),
    ParamSpec('chunk_period', MOTION.chunk_period, 'Time between two chunks sent', 's',
              min=0.01, max=10.0),
    ParamSpec('horizon', MOTION.horizon, 'How far ahead of now a chunk follows the plan '
              'before its stop (at least 2 chunk_period)', 's', min=0.02, max=60.0),
    ParamSpec('start_delay', MOTION.start_delay, 'From the first chunk to the start of the '
              'motion', 's', min=0.0, max=10.0),
    ParamSpec('state_timeout', 0.5, '/joint_states silent this long stops the arm', 's',
              min=0.01, max=60.0),
    ParamSpec('wait_timeout', 10.0, 'Longest wait at start for /joint_states and for the '
              'controller', 's', min=0.0),
    ParamSpec('use_action', False, 'Send FollowJointTrajectory goals (needs control_msgs) '
              'instead of publishing on the topic'),
    ParamSpec('action_name', ACTION, 'FollowJointTrajectory action of the controller'),
    ParamSpec('stats_file', '', 'Write the plan (origin, start, seed, margins) and what '
              'happened as JSON on exit; empty: never'),
)


class ExcitationNode(Node):
    """Send the excitation in stoppable chunks; stop smoothly on request."""

    def __init__(self) -> None:
        super().__init__(NAME)
        s = self.settings = declare_parameters(self, PARAMETERS)
        if s['horizon'] < 2.0 * s['chunk_period']:
            raise ConfigError(f"parameter 'horizon' ({s['horizon']:g} s) must be at least "
                              f"2 chunk_period ({2.0 * s['chunk_period']:g} s)")
        try:
            self.limits = load_motion_limits(
                urdf_file=s['urdf_file'], robot_description=s['robot_description'],
                joint_names=s['joint_names'], robot_config=s['robot_config'],
                acceleration_max=s['acceleration_max'])
            self.margined = self.limits.with_margins(
                s['position_margin'], s['velocity_scale'], s['acceleration_scale'])
        except LimitsError as exc:
            raise ConfigError(str(exc)) from None
        self.send = self._make_sender()
        # raw: only the arrival counts while moving; the positions are read once, at start
        self.state: tuple[float, bytes] | None = None
        self.states_topic = self.create_subscription(
            JointState, JOINT_STATES, self.on_joint_state,
            QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT),
            raw=True).topic_name
        self.create_service(Trigger, '~/stop', self.on_stop)
        self.stop_requested = False
        self.exit_status = 0
        self.plan: ExcitationPlan | None = None
        self.origin_ns = 0
        self.last: Chunk | None = None
        self.sent = 0
        self.stop_reason = ''
        self.get_logger().info(
            f'joints {list(self.limits.names)} from {self.limits.source}: within '
            f'{s["position_margin"]:g} of the ranges, {s["velocity_scale"]:g} of the velocity '
            f'and {s["acceleration_scale"]:g} of the acceleration limits')

    # -- boundary ----------------------------------------------------------------------------

    def _make_sender(self) -> Callable[[JointTrajectory], None]:
        """A function sending a JointTrajectory: the topic's publisher, or the action's."""
        if not self.settings['use_action']:
            self.publisher = self.create_publisher(
                JointTrajectory, JOINT_TRAJECTORY,
                QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
            self.controller_ready = lambda: self.publisher.get_subscription_count() > 0
            self.controller_name = self.publisher.topic_name
            return self.publisher.publish
        try:
            from control_msgs.action import FollowJointTrajectory
        except ImportError:
            raise ConfigError('use_action needs control_msgs (a ROS install has it: '
                              'ros-jazzy-control-msgs); without it, publish on the topic '
                              '(use_action false)') from None
        from rclpy.action import ActionClient

        client = ActionClient(self, FollowJointTrajectory, self.settings['action_name'])
        self.controller_ready = client.server_is_ready
        self.controller_name = self.settings['action_name']

        def send_goal(trajectory: JointTrajectory) -> None:
            client.send_goal_async(FollowJointTrajectory.Goal(trajectory=trajectory))
        return send_goal

    def on_joint_state(self, msg: bytes) -> None:
        """Keep the latest joint state (serialised) and when it came."""
        self.state = (time.monotonic(), msg)

    def on_stop(self, request: Trigger.Request, response: Trigger.Response
                ) -> Trigger.Response:
        """``~/stop``: bring the arm to rest (the loop sends the stop)."""
        response.success = not self.stop_requested
        response.message = ('stopping: the arm comes to rest along its path'
                            if response.success else 'already stopping')
        self.stop_requested = True
        return response

    def trajectory_msg(self, chunk: Chunk) -> JointTrajectory:
        """A chunk as a JointTrajectory whose header.stamp is the plan's origin."""
        msg = JointTrajectory()
        msg.header.stamp = ns_to_stamp(self.origin_ns)
        msg.joint_names = list(self.limits.names)
        points = []
        for t, q, qd, qdd in zip(chunk.times.tolist(), chunk.q.tolist(), chunk.qd.tolist(),
                                 chunk.qdd.tolist()):
            sec, nanosec = divmod(round(t * NS_PER_S), NS_PER_S)
            points.append(JointTrajectoryPoint(
                positions=q, velocities=qd, accelerations=qdd,
                time_from_start=DurationMsg(sec=sec, nanosec=nanosec)))
        msg.points = points
        return msg

    # -- run ---------------------------------------------------------------------------------

    def fail(self, message: str, status: int) -> None:
        """Report ``message`` as the node's one error line; exit with ``status``."""
        print(f'{NAME}: error: {message}', file=sys.stderr, flush=True)
        self.exit_status = status

    def now_ns(self) -> int:
        return self.get_clock().now().nanoseconds

    def plan_time(self) -> float:
        """Plan time now (s): negative before the motion starts."""
        return (self.now_ns() - self.origin_ns) / NS_PER_S

    def loop(self, executor: Executor, stop: threading.Event) -> None:
        """Wait for the arm and its controller, send the chunks, stop smoothly."""
        s = self.settings
        optimized = self.optimize() if s['plan'] == 'optimized' else None
        if s['plan'] == 'optimized' and optimized is None:
            return
        start = self.wait_for_start(executor, stop)
        if start is None:
            return
        self.plan = ExcitationPlan(self.margined, start, seed=s['seed'], excitation=optimized)
        self.origin_ns = self.now_ns() + round(s['start_delay'] * NS_PER_S)
        end = self.plan.approach_duration + s['duration'] if s['duration'] > 0 else None
        self.get_logger().info(
            f'from {np.round(start, 4).tolist()}: approach of {self.plan.approach_duration:g} s, '
            f'then the {s["plan"]} excitation (seed {s["seed"]}) '
            + (f'for {s["duration"]:g} s' if end is not None else 'until stopped')
            + f', sent to {self.controller_name}')
        next_send = time.monotonic()
        while True:
            executor.spin_once(timeout_sec=SPIN_PERIOD)
            t = self.plan_time()
            reason = self.stop_request(stop)
            if reason:
                self.stop_reason = reason
                self.get_logger().info(f'{reason}: stopping')
                self.send_stop(t)
                break
            if end is not None and self.last is not None and self.last.stop_time >= end:
                if t >= self.last.rest_time:
                    self.stop_reason = 'duration reached'
                    break
                continue
            if time.monotonic() >= next_send:
                next_send = max(next_send + s['chunk_period'], time.monotonic())
                stop_time = t + s['horizon']
                if not self.send_chunk(t, stop_time if end is None else min(stop_time, end)):
                    return
        self.wait_for_rest(executor)

    def optimize(self) -> OptimizedExcitation | None:
        """The optimised excitation for the URDF's physical model; None (and the error
        reported) if the URDF has no model Pinocchio can build."""
        from scara_ident_ros.dynamics.physical_model import PhysicalModel
        from scara_ident_ros.excitation.optimized_excitation import optimize_excitation
        from scara_ident_ros.excitation.self_collision import self_collision

        s = self.settings
        names = list(self.limits.names)
        self.get_logger().info(f'optimising the excitation ({s["harmonics"]} harmonics, '
                               f'{s["base_period"]:g} s period, at most '
                               f'{OPTIMIZE_SECONDS:g} s)')
        try:
            model = (PhysicalModel.from_urdf_file(s['urdf_file'], joint_names=names)
                     if s['urdf_file'] else
                     PhysicalModel(s['robot_description'], joint_names=names))
            collision = (self_collision(s['urdf_file'], names, self.margined.centre)
                         if s['urdf_file'] else None)
            found = optimize_excitation(model, self.margined, seed=s['seed'],
                                        n_harmonics=s['harmonics'], period=s['base_period'],
                                        max_seconds=OPTIMIZE_SECONDS, collision=collision)
        except ScaraIdentError as exc:
            self.fail(f'cannot optimise the excitation: {exc}', 2)
            return None
        self.get_logger().info(
            f'optimised in {found.seconds:.0f} s: condition number '
            f'{found.start_condition:.4g} at the start, {found.condition:.4g} at the end; '
            + found.collision_summary())
        return found

    def stop_request(self, stop: threading.Event) -> str:
        """Why the arm must stop now ('' if it need not)."""
        if stop.is_set():
            return 'interrupted'
        if self.stop_requested:
            return '~/stop called'
        assert self.state is not None
        silent = time.monotonic() - self.state[0]
        if silent > self.settings['state_timeout']:
            self.fail(f'no {self.states_topic} for {silent:.2f} s: bringing the arm to rest',
                      1)
            return f'{self.states_topic} lost'
        return ''

    def send_chunk(self, t: float, stop_time: float) -> bool:
        """Send the plan from now to ``stop_time``, then its stop; False if it is refused."""
        assert self.plan is not None
        step = self.settings['point_period']
        chunk = make_chunk(self.plan, t - step, max(stop_time, t + STOP_LEAD, 0.0), step,
                           self.margined)
        broken = self.margined.violations(chunk.q, chunk.qd, chunk.qdd,
                                          position_hull=self.plan.start)
        if broken:  # never sent: the last chunk sent brings the arm to rest by itself
            self.fail(f'a chunk would leave the limits ({"; ".join(broken)}): not sent', 1)
            return False
        self.send(self.trajectory_msg(chunk))
        self.last = chunk
        self.sent += 1
        return True

    def send_stop(self, t: float) -> None:
        """Stop ``STOP_LEAD`` from now, unless the last chunk's own stop begins sooner."""
        if self.last is not None and self.last.stop_time <= t + STOP_LEAD:
            return  # the arm follows the last chunk's stop already, or will before a new one
        self.send_chunk(t, t + STOP_LEAD)

    def wait_for_rest(self, executor: Executor) -> None:
        """Spin until the last chunk has brought the arm to rest."""
        if self.last is None:
            return
        self.get_logger().info(f'at rest in {self.last.rest_time - self.plan_time():.2f} s')
        while self.plan_time() < self.last.rest_time:
            executor.spin_once(timeout_sec=SPIN_PERIOD)
        self.get_logger().info(f'at rest after {self.sent} chunks')

    def wait_for_start(self, executor: Executor, stop: threading.Event) -> np.ndarray | None:
        """The arm's position once /joint_states and the controller are there; None (and
        the error reported) if they are not within ``wait_timeout`` or the start is bad."""
        deadline = time.monotonic() + self.settings['wait_timeout']
        while self.state is None or not self.controller_ready():
            if stop.is_set():
                return None
            if time.monotonic() > deadline:
                what = (f'no {self.states_topic}' if self.state is None
                        else f'no controller on {self.controller_name}')
                self.fail(f'{what} after {self.settings["wait_timeout"]:g} s', 2)
                return None
            executor.spin_once(timeout_sec=0.05)
        latest = deserialize_message(self.state[1], JointState)
        names, positions = list(latest.name), list(latest.position)
        missing = [name for name in self.limits.names if name not in names]
        if missing or len(positions) != len(names):
            self.fail(f'joints {missing} are not in {self.states_topic} (it has {names})'
                      if missing else f'{self.states_topic} has {len(names)} names and '
                      f'{len(positions)} positions', 2)
            return None
        start = np.array([positions[names.index(name)] for name in self.limits.names])
        outside = self.limits.outside(start)
        if outside:
            self.fail(f'the arm starts outside its limits: {", ".join(outside)}', 2)
            return None
        return start

    def close(self) -> None:
        """Write the stats file, if asked for."""
        if not self.settings['stats_file']:
            return
        s = self.settings
        stats = {
            'joint_names': list(self.limits.names), 'seed': s['seed'], 'plan': s['plan'],
            'position_margin': s['position_margin'], 'velocity_scale': s['velocity_scale'],
            'acceleration_scale': s['acceleration_scale'],
            'start': None if self.plan is None else self.plan.start.tolist(),
            'origin_ns': self.origin_ns,
            'approach_duration': None if self.plan is None else self.plan.approach_duration,
            'chunks_sent': self.sent, 'stop_reason': self.stop_reason,
            'stop_time': None if self.last is None else self.last.stop_time,
            'rest_time': None if self.last is None else self.last.rest_time,
            'exit_status': self.exit_status}
        Path(s['stats_file']).write_text(json.dumps(stats, indent=1))


def main(args: list[str] | None = None) -> None:
    """Console script ``excitation``."""
    built: list[ExcitationNode] = []

    def factory() -> ExcitationNode:
        built.append(ExcitationNode())
        return built[0]

    status = run_node(NAME, factory, args, description=__doc__ or '', parameters=PARAMETERS)
    sys.exit(status or (built[0].exit_status if built else 0))


if __name__ == '__main__':
    main()
