"""``identifier``: learns a robot's inverse dynamics online from ``joint_states``.

For every ``sensor_msgs/JointState`` it predicts the joint efforts from (q, q', q'')
*before* learning from that sample (an honest a-priori prediction), publishes the
prediction on ``identified_torque`` (same joint names, ``effort`` = predicted
torque/force, ``header.stamp`` = the stamp of the sample it predicts), then learns from it
(``trainer``: ``lm``, Levenberg–Marquardt steps on a reservoir of the whole stream, or
``bp``, the paper's per-sample back-propagation). q'' is estimated zero-phase by default
(``differentiator: centred``), so each prediction is published ``window // 2`` samples
after its sample (10 ms at 1 kHz). A fraction of the samples (whole blocks) is never learnt:
the model's error on them is the validation NMSE. All of that is
:class:`~scara_ident_ros.identification.OnlineIdentifier`; this node converts messages,
publishes, checkpoints and logs.

``identification_mse`` (``std_msgs/Float64MultiArray``) carries the errors,
``data = [mse_1 .. mse_n, mse_total, nmse_1 .. nmse_n, nmse_total,
vnmse_1 .. vnmse_n, vnmse_total]`` with ``layout.dim[0]`` labelled
``metric:mse,nmse,validation_nmse`` (size 3) and ``layout.dim[1]`` labelled
``joint:<name_1>,...,<name_n>,total`` (size n + 1). MSE is in (N·m)² or N²; NMSE is MSE
divided by the variance of that joint's effort over the same window; the validation NMSE
is the current model's over the held-out samples kept so far (NaN until there are 100).

While it runs: ``learn``, ``learning_rate``, ``momentum``, ``mse_window``, ``mse_rate_hz``,
``checkpoint_period``, ``lm_steps`` and ``lm_interval`` can be set (``ros2 param set``) and
take effect at once; ``~/save_model`` and ``~/reset`` (``std_srvs/Trigger``) save the model
now or start again from fresh weights; ``/diagnostics`` says once a second how it does
(:mod:`scara_ident_ros.identification.health`).
"""
from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension
from std_srvs.srv import Trigger

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.identification import (DIFFERENTIATORS, LIMIT_NAMES, TRAINERS, CoreSettings,
                                            ErrorWindow, LazyCore, OnlineIdentifier, ReservoirLM,
                                            SkipReason, StepResult, check_warm_start,
                                            load_joint_limits, make_differentiator)
from scara_ident_ros.identification.health import (Deltas, Health, LossCounter,
                                                   identifier_health)
from scara_ident_ros.methods import METHODS
from scara_ident_ros.mse_layout import encode_mse
from scara_ident_ros.nn import FeedForwardNet, ModelFormatError
from scara_ident_ros.nodes.diagnostics import Diagnostics
from scara_ident_ros.nodes.messages import joint_state, stamp_to_ns
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.publisher_watch import PublisherWatch
from scara_ident_ros.nodes.runtime import ConfigError, run_node
from scara_ident_ros.paths import unwritable_file
from scara_ident_ros.topics import JOINT_STATES, MSE, TORQUE

__all__ = ['IdentifierNode', 'main']

QOS_DEPTH = 5000  # messages: 5 s at 1 kHz may queue before any is dropped
STREAM_QOS = QoSProfile(depth=QOS_DEPTH, history=HistoryPolicy.KEEP_LAST,
                        reliability=ReliabilityPolicy.RELIABLE)  # torques
#: joint_states: reliable, keep all. Fast DDS then holds a bounded number of unread samples
#: and stops acknowledging new ones while that is full, so a publisher that paces itself to
#: acknowledgements (the player at rate max) loses nothing however slow the identifier;
#: keep-last acknowledged every sample and dropped the oldest unread ones (7,091 of 10,000
#: processed at rate max).
INPUT_QOS = QoSProfile(depth=QOS_DEPTH, history=HistoryPolicy.KEEP_ALL,
                       reliability=ReliabilityPolicy.RELIABLE)
STATS_PERIOD = 10.0  # s between statistics log lines
WARN_PERIOD = 5.0  # s between two warnings about skipped samples
WAIT_POLL_PERIOD = 0.02  # s between two looks at the outputs' subscriber counts
FLUSH_TIMEOUT = 2.0  # s on shutdown for the subscribers to acknowledge the last predictions
# Why a read-only parameter is fixed at start (shown by `ros2 param describe`)
NETWORK = "the network's shape and inputs (a saved model keeps them)"
HOLDOUT = 'which samples are held out must not change under the validation score'
ESTIMATE = "the q'' estimate keeps a history of samples"
LIMITS = "the network's input and output scaling"
START = 'used at start only'

PARAMETERS = (
    ParamSpec('method', 'ffs', 'Network: FFS (sigmoid, default: it identifies best, README '
              "'Results'), FFMW (MSLOG, the paper's) or FFW (SLOG)",
              choices=tuple(METHODS), fixed=NETWORK),
    ParamSpec('joint_names', [], 'Joints to identify, in this order; empty: the joints of '
              'the first valid message (or of the warm-start model)', items=str, fixed=NETWORK),
    ParamSpec('min_joints', 1, 'Without joint_names: take the joints of the first valid '
              'message naming at least this many (a partial message does not fix the set)',
              min=1, max=1000, fixed=NETWORK),
    ParamSpec('hidden_units', 40, 'Hidden units of the network', min=1, max=10_000,
              fixed=NETWORK),
    ParamSpec('seed', 0, 'Seed of the initial weights, the reservoir and the validation '
              'blocks', min=0, fixed='the weights are drawn once (~/reset draws them again)'),
    ParamSpec('learning_rate', 0.0, "Online learning rate of trainer bp; 0: the method's "
              'default', min=0.0, max=10.0, read_only=False),
    ParamSpec('momentum', -1.0, "Online momentum in [0, 1) of trainer bp; negative: the "
              "method's default", min=-1.0, max=0.999, read_only=False),
    ParamSpec('k', 2.5, 'MSLOG gain K (ffmw only)', fixed=NETWORK),
    ParamSpec('a', 5.0, 'MSLOG divisor a in z = (x·v − b)/a (ffmw only)', fixed=NETWORK),
    ParamSpec('b', 5.0, 'MSLOG offset b (ffmw only)', fixed=NETWORK),
    ParamSpec('learn', True, 'Learn online; false: predict only (samples without effort are '
              'then predicted too)', read_only=False),
    ParamSpec('trainer', 'lm', 'Online training: lm (Levenberg-Marquardt steps on a reservoir '
              'of the whole stream, generalizes) or bp (the paper: one back-propagation step '
              'per sample, tracks)', choices=TRAINERS, fixed='the trainer keeps its state'),
    ParamSpec('reservoir_size', 4000, 'Samples of the stream kept for the lm trainer',
              min=10, max=1_000_000, fixed='the reservoir is allocated once'),
    ParamSpec('lm_steps', 2, 'Levenberg-Marquardt steps of the lm trainer per update', min=1,
              max=100, read_only=False),
    ParamSpec('lm_interval', 200, 'Samples between two updates of the lm trainer', min=1,
              max=1_000_000, read_only=False),
    ParamSpec('lm_float64', False, 'lm trainer: assemble its normal equations in float64 '
              '(1.5x the CPU; on all-random weights, with lm_slow_share 0.25, it brought 5 '
              'seeds of 10 under 1e-3 on every joint; the friction steps bring all)',
              fixed='the trainer is built once'),
    ParamSpec('lm_slow_share', 0.0, 'lm trainer: share of reservoir_size kept for samples '
              'where some joint moves slower than 1 % of its velocity limit (the friction '
              'step at zero speed); 0: one uniform reservoir', min=0.0, max=0.5,
              fixed='the reservoir is allocated once'),
    ParamSpec('lm_friction_steps', True, 'lm trainer: the first hidden units start as steps '
              "of each joint's speed at 0, the shape of Coulomb friction (half-widths 6.4, "
              '1.6, 0.4, 0.1 and 0.025 % of the velocity limit), the others random; false: all '
              'random (joint 4 then misses 1e-3 after 120 s)', fixed=NETWORK),
    ParamSpec('validation_fraction', 0.1, 'Fraction of the samples (in blocks) never learnt, '
              'whose error is the validation NMSE; 0: none', min=0.0, max=0.9,
              fixed=HOLDOUT),
    ParamSpec('validation_block', 500, 'Samples per held-out block', min=1, max=1_000_000,
              fixed=HOLDOUT),
    ParamSpec('model_path', '', 'Warm-start from this saved model (.npz); empty: fresh',
              fixed='read once, at start'),
    ParamSpec('save_path', '', 'Save the model here periodically and on shutdown (atomically); '
              'a model already there is continued from, not replaced (unless model_path is '
              'given); empty: never', fixed='a model there is continued from at start'),
    ParamSpec('checkpoint_period', 60.0, 'Seconds between checkpoints to save_path; 0: only '
              'on shutdown (and ~/save_model)', 's', min=0.0, read_only=False),
    ParamSpec('mse_window', 1000, 'Samples in the windowed MSE (a change starts the window '
              'anew)', min=100, read_only=False),
    ParamSpec('mse_rate_hz', 10.0, 'Rate of identification_mse', 'Hz', min=0.01, max=1000.0,
              read_only=False),
    ParamSpec('differentiator', 'centred', 'How acceleration is estimated from velocity: '
              'centred (zero-phase, window // 2 samples late) or a causal filter',
              choices=DIFFERENTIATORS, fixed=ESTIMATE),
    ParamSpec('cutoff_hz', 50.0, 'Cut-off of the lowpass differentiator', 'Hz', min=0.1,
              fixed=ESTIMATE),
    ParamSpec('window', 21, 'Samples of the centred (odd) and polynomial differentiators',
              min=3, max=101, fixed=ESTIMATE),
    ParamSpec('limit_margin', 0.5, 'Refuse samples (out_of_limits) whose position leaves the '
              'joint range by more than this fraction of the range, or whose velocity or '
              'effort exceeds its limit by more than this fraction; negative: no check',
              min=-1.0, max=100.0, fixed=LIMITS),
    ParamSpec('max_gap', 0.02, 'A larger gap between stamps, if also longer than 5 observed '
              'sample periods (100 Hz: 50 ms), restarts the differentiator', 's', min=0.0,
              fixed=ESTIMATE),
    ParamSpec('robot_config', '', "Robot YAML whose joint limits scale the network's inputs "
              'and outputs; empty: the installed config/scara.yaml', fixed=LIMITS),
    ParamSpec('urdf_file', '', 'URDF whose joint <limit>s (position, velocity, effort), '
              'matched by joint name, replace those of robot_config; acceleration limits '
              "(URDF has none) stay robot_config's, or acceleration_max with joint_names; "
              'empty: none', fixed=LIMITS),
    ParamSpec('robot_description', '', 'The URDF as a string, as robot_state_publisher has '
              'it: used like urdf_file', fixed=LIMITS),
    ParamSpec('position_min', [], 'Per-joint position lower limits (rad or m); with the four '
              'below, replaces robot_config for another robot', items=float, fixed=LIMITS),
    ParamSpec('position_max', [], 'Per-joint position upper limits (rad or m)', items=float,
              fixed=LIMITS),
    ParamSpec('velocity_max', [], 'Per-joint |velocity| limits (rad/s or m/s)', items=float,
              fixed=LIMITS),
    ParamSpec('acceleration_max', [], 'Per-joint |acceleration| limits (rad/s² or m/s²)',
              items=float, fixed=LIMITS),
    ParamSpec('effort_max', [], 'Per-joint |effort| limits (N·m or N)', items=float,
              fixed=LIMITS),
    ParamSpec('wait_for_subscribers', 0, 'Subscribe joint_states only once identified_torque '
              'and identification_mse each have this many subscribers (e.g. a recorder), so '
              'that no prediction goes unheard; 0: at once', min=0, fixed=START),
    ParamSpec('wait_timeout', 30.0, 'Longest wait for those subscribers', 's', min=0.0,
              fixed=START),
    ParamSpec('stats_file', '', 'Write the final counters and errors here as JSON on '
              'shutdown; empty: never', fixed='checked writable at start'),
)
#: Rejections that mean the message's joints are not the identifier's
JOINT_SET_REASONS = (SkipReason.UNKNOWN_JOINT, SkipReason.MISSING_JOINT,
                     SkipReason.DUPLICATE_JOINT, SkipReason.JOINT_COUNT)


class IdentifierNode(Node):
    """Subscribe ``joint_states``; publish a-priori torque predictions and their error."""

    def __init__(self) -> None:
        super().__init__('identifier')
        self.settings = s = declare_parameters(self, PARAMETERS, on_change=self._apply)
        self.limits = load_joint_limits(
            joint_names=s['joint_names'], robot_config=s['robot_config'],
            urdf_file=s['urdf_file'], robot_description=s['robot_description'],
            explicit={key: s[key] for key in LIMIT_NAMES})
        names = list(s['joint_names'])
        for key in ('save_path', 'stats_file'):
            problem = unwritable_file(s[key]) if s[key] else ''
            if problem:
                raise ConfigError(f'{key} {s[key]}: {problem}')
        model_path = s['model_path']
        # A restart continues from what was learnt instead of replacing it.
        continuing = bool(not model_path and s['save_path'] and Path(s['save_path']).exists())
        if continuing:
            model_path = s['save_path']
        network = self._load(model_path) if model_path else None
        if network is not None:
            names = check_warm_start(network, names, source=model_path, method=s['method'])
            if continuing:
                self.get_logger().info(f'continuing from the model at save_path {model_path}')
        self.max_lag_ns = 0  # ns, since the last statistics line
        self.worst_lag_ns = 0  # ns, since start
        self.last_warning = 0.0
        # checked at startup (a bad window ends it in one line), used once the joints are known
        self.differentiator = make_differentiator(s['differentiator'], window=s['window'],
                                                  cutoff_hz=s['cutoff_hz'])
        self.lazy = LazyCore(self.limits, network)  # the core, once the joints are known
        missing_limits = self._build(names) if names else ''
        if missing_limits:
            raise ConfigError(f'joint_names: {missing_limits}')
        self.frame_id = ''  # header.frame_id of the latest sample, given to its predictions
        self.torque_publisher = self.create_publisher(JointState, TORQUE, STREAM_QOS)
        self.mse_publisher = self.create_publisher(Float64MultiArray, MSE, 10)
        self.subscription: Subscription | None = None
        self.mse_timer = self.create_timer(1.0 / s['mse_rate_hz'], self.publish_mse)
        self.create_timer(STATS_PERIOD, self.log_stats)
        self.checkpoint_timer: Timer | None = None
        self._start_checkpoints()
        self.previous: list[dict[str, Any]] = []  # summaries from before each ~/reset
        self.loss = LossCounter()  # samples missing from the stream, from the stamps
        self.last_sample: float | None = None  # monotonic s of the latest sample
        self.period_lag_ns = 0  # ns, largest lag since the last diagnostics report
        self.deltas = Deltas()
        self.diagnostics = Diagnostics(self, 'identification', self.health)
        self.create_service(Trigger, '~/save_model', self.on_save_model)
        self.create_service(Trigger, '~/reset', self.on_reset)
        self.joints_text = str(names or '(from the first message)')
        if s['wait_for_subscribers'] > 0:
            self.wait_deadline = time.monotonic() + s['wait_timeout']
            self.wait_timer = self.create_timer(WAIT_POLL_PERIOD, self._subscribe_when_heard)
            self.get_logger().info(
                f"waiting for {s['wait_for_subscribers']} subscriber(s) on "
                f'{self.torque_publisher.topic_name} and {self.mse_publisher.topic_name}')
        else:
            self._subscribe()

    @property
    def network(self) -> FeedForwardNet | None:
        """The network: a warm start, or built with the core."""
        return self.lazy.network

    @property
    def core(self) -> OnlineIdentifier | None:
        """The online core, once the joints are known."""
        return self.lazy.core

    @property
    def names(self) -> list[str]:
        """The identified joints, once the core is built."""
        return self.lazy.names

    def _subscribe(self) -> None:
        """Subscribe ``joint_states``: from now on samples are processed."""
        s = self.settings
        self.subscription = self.create_subscription(
            JointState, JOINT_STATES, self.on_joint_state, INPUT_QOS)
        self.publisher_watch = PublisherWatch(self, self.subscription.topic_name)
        self.get_logger().info(
            f"{s['method'].upper()} identifier on {self.subscription.topic_name} → "
            f'{self.torque_publisher.topic_name}, joints {self.joints_text}, '
            f"learning {'on' if s['learn'] else 'off'}")

    def _subscribe_when_heard(self) -> None:
        """Timer: subscribe once both outputs have ``wait_for_subscribers`` subscribers."""
        wanted = self.settings['wait_for_subscribers']
        heard = min(self.torque_publisher.get_subscription_count(),
                    self.mse_publisher.get_subscription_count())
        if heard < wanted and time.monotonic() < self.wait_deadline:
            return
        if heard < wanted:
            self.get_logger().warning(
                f'only {heard} of {wanted} subscribers on the outputs after '
                f"{self.settings['wait_timeout']:g} s; subscribing anyway")
        self.wait_timer.cancel()
        self.destroy_timer(self.wait_timer)
        self._subscribe()

    # ------------------------------------------------------------------ while running
    def _apply(self, changed: dict[str, Any]) -> None:
        """Make parameters set while running take effect (they passed their checks)."""
        s = self.settings
        self.get_logger().info('set ' + ', '.join(f'{k} = {v!r}' for k, v in changed.items()))
        method = METHODS[s['method']]
        if self.network is not None and 'learning_rate' in changed:
            self.network.learning_rate = s['learning_rate'] or method.learning_rate
        if self.network is not None and 'momentum' in changed:
            self.network.momentum = s['momentum'] if s['momentum'] >= 0 else method.momentum
        if self.core is not None:
            self.core.learn = s['learn']
            self.core.stage.check.need_effort = s['learn']  # predict-only takes any sample
            if 'mse_window' in changed:
                self.core.errors = ErrorWindow(self.core.n_joints, s['mse_window'])
            if isinstance(self.core.trainer, ReservoirLM):
                self.core.trainer.interval = s['lm_interval']
                self.core.trainer.steps_per_update = s['lm_steps']
        if 'mse_rate_hz' in changed:
            self.destroy_timer(self.mse_timer)
            self.mse_timer = self.create_timer(1.0 / s['mse_rate_hz'], self.publish_mse)
        if 'checkpoint_period' in changed:
            self._start_checkpoints()

    def _start_checkpoints(self) -> None:
        """(Re)start the checkpoint timer for the current ``checkpoint_period``."""
        if self.checkpoint_timer is not None:
            self.destroy_timer(self.checkpoint_timer)
            self.checkpoint_timer = None
        if self.settings['save_path'] and self.settings['checkpoint_period'] > 0:
            self.checkpoint_timer = self.create_timer(self.settings['checkpoint_period'],
                                                      self.checkpoint)

    def on_save_model(self, request: Trigger.Request,
                      response: Trigger.Response) -> Trigger.Response:
        """Service ``~/save_model``: save to ``save_path`` now, or say why not."""
        response.success, response.message = self.save_model()
        self.get_logger().info(f'~/save_model: {response.message}')
        return response

    def on_reset(self, request: Trigger.Request, response: Trigger.Response
                 ) -> Trigger.Response:
        """Service ``~/reset``: start again from fresh weights, counters kept apart.

        The summary of before (counters, errors) is logged and kept in ``previous`` of the
        statistics; the samples whose prediction was pending are dropped.
        """
        names = self.names if self.core is not None else None
        if names is None and self.network is None:
            response.success = False
            response.message = 'nothing to reset: no model yet (no valid sample so far)'
            return response
        before = self.summary()
        before.pop('previous', None)  # each reset's own counters, one entry per reset
        self.previous.append(before)
        self.lazy.reset()
        s = self.settings
        self.differentiator = make_differentiator(s['differentiator'], window=s['window'],
                                                  cutoff_hz=s['cutoff_hz'])
        if names is not None and (why := self._build(names)):
            self._warn(why)  # a warm start's joints without limits: the next sample tries
        response.success = True
        response.message = (f"fresh weights (seed {s['seed']}); before the reset: "
                            f"processed {before['processed']}, learned "
                            f"{before.get('learned', 0)}, validation NMSE "
                            f"{before.get('validation_nmse_total')}")
        self.get_logger().info(f'~/reset: {response.message}')
        return response

    def health(self, period_s: float) -> Health:
        """The node's health over the last ``period_s`` s, for ``/diagnostics``."""
        counts = self.lazy.counts
        skipped = sum(counts.skipped.values())
        recent = self.deltas(processed=counts.processed, skipped=skipped, lost=self.loss.lost)
        error_finite, validation = True, None
        if self.core is not None:
            if self.core.errors.count:
                error_finite = bool(np.isfinite(self.core.error_stats().mse_total))
            stats = self.core.validation_stats()
            validation = float(stats.nmse_total) if stats is not None else None
        lag_ns, self.period_lag_ns = self.period_lag_ns, 0
        return identifier_health(
            period_s=period_s, processed=counts.processed, skipped=skipped,
            since_sample_s=(None if self.last_sample is None
                            else time.monotonic() - self.last_sample),
            lost=self.loss.lost, learnt=counts.learned, recent_processed=int(recent['processed']),
            recent_skipped=int(recent['skipped']), recent_lost=int(recent['lost']),
            lag_s=lag_ns / 1e9 if lag_ns else None, error_finite=error_finite,
            validation_nmse=validation, learning=self.settings['learn'])

    # ------------------------------------------------------------------ configuration
    def _load(self, path: str) -> FeedForwardNet:
        try:
            network = FeedForwardNet.load(path)
        except (ModelFormatError, OSError) as exc:
            raise ConfigError(f'cannot warm-start: {exc}') from None
        s = self.settings
        if s['learning_rate'] > 0:
            network.learning_rate = s['learning_rate']
        if s['momentum'] >= 0:
            network.momentum = s['momentum']
        return network

    def _build(self, names: list[str]) -> str:
        """Build the core for ``names`` (at start and on ~/reset); return '' or why not (a
        joint without limits)."""
        why = self.lazy.build(names, CoreSettings.of(self.settings), self.differentiator)
        if not why:
            self.torque_msg = joint_state(0, names, effort=np.zeros(len(names)))
        return why

    # ------------------------------------------------------------------ per sample
    def on_joint_state(self, msg: JointState) -> None:
        """Predict, publish, learn: one input sample."""
        self.last_sample = time.monotonic()
        self.loss.observe(stamp_to_ns(msg.header.stamp))
        self.publisher_watch.stamps.observe(stamp_to_ns(msg.header.stamp))
        if self.core is None and not self._build_from(msg):
            return
        assert self.core is not None  # built by _build_from
        stamp_ns = stamp_to_ns(msg.header.stamp)
        self.frame_id = msg.header.frame_id
        results = self.core.process(stamp_ns, msg.name, msg.position, msg.velocity,
                                    msg.effort)
        if results and results[0].reason in JOINT_SET_REASONS:
            self._warn(f'skipped a sample ({results[0].reason.value}): it names joints '
                       f'{list(msg.name)}, the identifier identifies {self.names} (set '
                       'joint_names, or min_joints to wait for a message naming them all)')
            return
        self._publish(results)

    def _publish(self, results: list[StepResult], *, measure_lag: bool = True) -> None:
        """Publish each prediction, stamped with its sample; warn about rejections.

        ``measure_lag``: record how late each prediction is (wall clock minus its stamp);
        not for those let out on shutdown, whose lag is the time since the last sample.
        """
        assert self.core is not None
        out = self.torque_msg  # reused: publish() serialises it before returning
        for result in results:
            if result.effort is None:
                assert result.reason is not None
                if result.reason is not SkipReason.WARMING_UP:
                    self._warn(f'skipped a sample ({result.reason.value}); '
                               f'{sum(self.core.counts.skipped.values())} so far')
                continue
            out.header.stamp.sec, out.header.stamp.nanosec = divmod(result.stamp_ns,
                                                                    1_000_000_000)
            out.header.frame_id = self.frame_id
            out.effort = result.effort.tolist()
            self.torque_publisher.publish(out)
            if not measure_lag:
                continue
            lag_ns = time.time_ns() - result.stamp_ns
            self.period_lag_ns = max(self.period_lag_ns, lag_ns)
            if lag_ns > self.max_lag_ns:
                self.max_lag_ns = lag_ns
                self.worst_lag_ns = max(self.worst_lag_ns, lag_ns)

    def _build_from(self, msg: JointState) -> bool:
        """Build for the joints of ``msg`` if it is valid; else count it as skipped."""
        skipped = self.lazy.first(CoreSettings.of(self.settings), self.differentiator,
                                  stamp_to_ns(msg.header.stamp), msg.name, msg.position,
                                  msg.velocity, msg.effort)
        if skipped is None:
            self.torque_msg = joint_state(0, self.names, effort=np.zeros(len(self.names)))
            return True
        if skipped.note:
            self._warn(skipped.note)
        self._warn(f'skipped a sample ({skipped.reason.value}) before the first valid one')
        return False

    def _warn(self, text: str) -> None:
        now = time.monotonic()
        if now - self.last_warning >= WARN_PERIOD:
            self.last_warning = now
            self.get_logger().warning(text)

    # ------------------------------------------------------------------ periodic
    def publish_mse(self) -> None:
        """Publish the windowed per-joint and overall MSE and NMSE."""
        if self.core is None or self.core.errors.count == 0:
            return
        stats = self.core.error_stats()
        validation = self.core.validation_stats()
        dims, data = encode_mse(self.names, stats, validation)
        msg = Float64MultiArray(data=data)
        msg.layout.dim = [MultiArrayDimension(**dim._asdict()) for dim in dims]
        self.mse_publisher.publish(msg)

    def handled(self) -> int:
        """Samples taken from ``joint_states`` so far (a stop drains until it stays put)."""
        return self.lazy.counts.processed

    def summary(self) -> dict[str, Any]:
        """Counters and errors so far, as plain data."""
        if self.core is None:
            early = self.lazy.early
            return {'method': self.settings['method'], 'processed': early.processed,
                    'skipped': {reason.value: n for reason, n in early.skipped.items()
                                if n}}
        counts = self.core.counts
        stats = self.core.error_stats()
        validation = self.core.validation_stats()
        return {
            'method': self.settings['method'], 'trainer': self.settings['trainer'],
            'joint_names': self.names,
            'processed': counts.processed, 'predicted': counts.predicted,
            'learned': counts.learned, 'held_out': counts.held_out, 'refused': counts.refused,
            'clipped': counts.clipped, 'no_effort': counts.no_effort,
            'pending': counts.pending,
            'skipped': {reason.value: n for reason, n in counts.skipped.items() if n},
            'mse': stats.mse.tolist(), 'nmse': stats.nmse.tolist(),
            'mse_total': float(stats.mse_total), 'nmse_total': float(stats.nmse_total),
            'validation_nmse': validation.nmse.tolist() if validation is not None else None,
            'validation_nmse_total': (float(validation.nmse_total) if validation is not None
                                      else None),
            'max_lag_ms': self.worst_lag_ns / 1e6, 'lost': self.loss.lost,
            'joint_states_publishers': self.publisher_watch.most_publishers,
            'stamps_backward': self.publisher_watch.stamps.backward,
            **({'previous': self.previous} if self.previous else {}),
        }

    def log_stats(self) -> None:
        """Log counters, skipped samples by reason, lag and the windowed error."""
        info = self.summary()
        validation = info.get('validation_nmse_total')
        if info['processed'] and self.core is None:
            self.get_logger().info(f"processed {info['processed']}, no valid sample yet: "
                                   f"skipped {info['skipped']}")
        elif info['processed']:
            no_effort = f", {info['no_effort']} without effort" if info['no_effort'] else ''
            # steps refused by the trainer (not finite, or undone by bp's guard, which also
            # halves the learning rate) and predictions clipped to the effort limits
            no_effort += ''.join(f', {key} {info[key]}' for key in ('refused', 'clipped')
                                 if info.get(key))
            self.get_logger().info(
                f"processed {info['processed']}, learned {info['learned']}, held out "
                f"{info['held_out']}{no_effort}, skipped {info['skipped'] or 0}, max lag "
                f"{self.max_lag_ns / 1e6:.2f} ms, windowed MSE {info['mse_total']:.4g}, NMSE "
                f"{info['nmse_total']:.4g}, validation NMSE "
                f"{math.nan if validation is None else validation:.4g}")
        self.max_lag_ns = 0

    def save_model(self) -> tuple[bool, str]:
        """Save the model to ``save_path`` now (atomically); return success and what happened.

        The save is atomic, so a failed one leaves the previous file intact, and the network
        in memory keeps learning.
        """
        path = self.settings['save_path']
        if not path:
            return False, 'no save_path: start the node with -p save_path:=<file>.npz'
        if self.network is None or self.core is None:
            return False, 'no model yet: no valid sample has fixed the joints'
        try:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            self.network.save(path)
        except OSError as exc:
            return False, f'saving to {path} failed: {exc}'
        return True, f'saved to {path} after {self.core.counts.learned} learned samples'

    def checkpoint(self) -> None:
        """Save the model to ``save_path``, if there is one; a failure is logged, not fatal."""
        if self.settings['save_path'] and self.core is not None:
            saved, message = self.save_model()
            if not saved:
                self.get_logger().error(f'checkpoint: {message}')

    def close(self) -> None:
        """On shutdown: predict and learn the pending samples, checkpoint, final statistics.

        The last ``window // 2`` predictions are published here, just before the process
        ends: wait (at most :data:`FLUSH_TIMEOUT`) until the subscribers have acknowledged
        them, as the node is destroyed right after and would take them along.
        """
        if self.core is not None:
            results = self.core.finish()
            self._publish(results, measure_lag=False)
            if results:
                self.torque_publisher.wait_for_all_acked(Duration(seconds=FLUSH_TIMEOUT))
        self.checkpoint()
        self.log_stats()
        if self.settings['stats_file']:
            stats_file = Path(self.settings['stats_file'])
            stats_file.parent.mkdir(parents=True, exist_ok=True)
            stats_file.write_text(json.dumps(self.summary(), indent=1))


def main(args: list[str] | None = None) -> None:
    """Console script ``identifier``."""
    # One BLAS thread: the lm trainer's steps (684 unknowns) gain nothing from a second one,
    # and competing BLAS pools on a busy machine made them 5-10 times slower (2 cores, 3
    # identifiers: 300-500 ms a step instead of 70 ms, the node fell seconds behind).
    with single_blas_thread():
        status = run_node('identifier', IdentifierNode, args, description=__doc__ or '',
                          parameters=PARAMETERS)
    sys.exit(status)


if __name__ == '__main__':
    main()
