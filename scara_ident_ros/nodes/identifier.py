"""``identifier``: learns a robot's inverse dynamics online from ``joint_states``.

For every ``sensor_msgs/JointState`` it predicts the joint efforts from (q, q', q'')
*before* learning from the sample, publishes the prediction on ``identified_torque``
(stamped with the sample it predicts, ``window // 2`` samples late with the zero-phase q''
estimate; the last ones of a stream that ends come on stop, or ``end_history_after`` s
later), then learns from it (``trainer``). Blocks of samples are never learnt: the model's
error on them is the validation NMSE. The per-sample logic is
:class:`~scara_ident_ros.identification.OnlineIdentifier` under an
:class:`~scara_ident_ros.identification.session.IdentificationSession`; this node converts
messages, publishes, checkpoints and logs.

With ``methods`` (e.g. ``[ffmw, ffw, ffs]``) one subscription serves several networks: each
sample is checked and differentiated once, and each network publishes under ``<method>/``.

``external_torque`` carries measured − predicted effort; joints over their threshold are
reported on ``contact`` while detection is armed: every ``contact_calibration_period`` s the
held-out residuals set the thresholds, and detection is armed only when the model identifies
(validation NMSE below ``contact_arm_nmse``) and the false-alarm rate the residuals give is
at most ``contact_false_alarms_per_hour``; ``contact_armed`` says whether it is
(:mod:`scara_ident_ros.identification.contact_detector`). ``identification_mse`` carries
the windowed and validation errors (layout: :mod:`scara_ident_ros.mse_layout`).

Parameters that are not read-only take effect at once (``ros2 param set``); ``~/save_model``
and ``~/reset`` (``std_srvs/Trigger``) save now or start again from fresh weights;
``/diagnostics`` reports once a second (:mod:`scara_ident_ros.nodes.health`).
"""
from __future__ import annotations

import gc
import json
import sys
import time
from collections import deque
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import Trigger

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.identification.background_lm import prestart
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.parameters import IDENTIFIER_PARAMETERS
from scara_ident_ros.identification.reports import MethodReport, StreamFigures
from scara_ident_ros.identification.sample_outcome import Prediction
from scara_ident_ros.identification.sample_check import GAP_PERIODS
from scara_ident_ros.identification.session import IdentificationSession, MethodRun
from scara_ident_ros.identification.stream_clock import PathDelays
from scara_ident_ros.mse_layout import encode_mse
from scara_ident_ros.nodes.diagnostics import Diagnostics
from scara_ident_ros.nodes.health import Deltas, Health, LossCounter, identifier_health
from scara_ident_ros.nodes.joint_state_cdr import (JointStateReader, JointStateTemplate,
                                                   RawJointState)
from scara_ident_ros.nodes.messages import joint_state
from scara_ident_ros.nodes.realtime import REALTIME_PRIORITY
from scara_ident_ros.nodes.subscribers import WAIT_FOR_NODES, subscribers_heard
from scara_ident_ros.nodes.parameters import ParamSpec, declare_parameters
from scara_ident_ros.nodes.publisher_watch import PublisherWatch
from scara_ident_ros.nodes.runtime import run_node
from scara_ident_ros.paths import unwritable_file
from scara_ident_ros.topics import CONTACT, EXTERNAL_TORQUE, JOINT_STATES, MSE, TORQUE

CONTACT_ARMED = 'contact_armed'  # std_msgs/Bool: whether contact detection is armed

__all__ = ['IdentifierNode', 'main']

QOS_DEPTH = 5000  # messages: 5 s at 1 kHz may queue before any is dropped
STREAM_QOS = QoSProfile(depth=QOS_DEPTH, history=HistoryPolicy.KEEP_LAST,
                        reliability=ReliabilityPolicy.RELIABLE)  # torques
#: joint_states: reliable, keep all. Fast DDS then stops acknowledging while its unread
#: samples are full, so a publisher pacing itself to acknowledgements (the player at rate
#: max) loses nothing however slow the identifier; keep-last drops the oldest unread ones.
INPUT_QOS = QoSProfile(depth=QOS_DEPTH, history=HistoryPolicy.KEEP_ALL,
                       reliability=ReliabilityPolicy.RELIABLE)
STATS_PERIOD = 10.0  # s between statistics log lines
WARN_PERIOD = 5.0  # s between two warnings about skipped samples
WAIT_POLL_PERIOD = 0.02  # s between two looks at the outputs' subscriber counts
DEFAULT_PERIOD = 1e-3  # s: the sample period assumed until the stream shows its own
CALIBRATION_TICK = 0.05  # s between two steps of the contact calibration
CALIBRATION_SLICE = 2000  # held-out samples a calibration step predicts
FLUSH_TIMEOUT = 2.0  # s on shutdown for the subscribers to acknowledge the last predictions
SETTLE_LOSS_S = 0.2  # s without a sample after which a long stamp step's losses are counted
QUIET_TICK = 0.02  # s between two looks for a quiet stream (end_history_after)
#: Predict the pending samples once the stream has been quiet this long: the centred q''
#: waits for window // 2 later samples, which a stream that ended or paused does not send
END_HISTORY_AFTER = ParamSpec(
    'end_history_after', 0.0, 'Once no sample has come for this long (and for more than '
    'max_gap and 5 sample periods), predict and learn the pending samples as on stop and '
    'start a new history with the next sample: a subscriber then gets the last samples of '
    'a stream that ended or paused this much later, not when the node stops; 0: only on stop',
    's', min=0.0, fixed='a timer made at start')
#: The node's parameters: the identifier's (:mod:`scara_ident_ros.identification.parameters`),
#: then the node's own: the end of a quiet stream's history, the scheduling of its threads,
#: the nodes it waits for
PARAMETERS = (*IDENTIFIER_PARAMETERS, END_HISTORY_AFTER, REALTIME_PRIORITY, WAIT_FOR_NODES)
#: contact messages are rare: a few seconds of them at 1 kHz
CONTACT_QOS = QoSProfile(depth=1000, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE)
#: contact_armed: the latest state, kept for subscribers that join later
ARMED_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                       reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Outputs:
    """The publishers of a method (``run``) of ``node``, in namespace ``prefix`` relative to
    the node's ('' or ``'<method>/'``), and the messages its predictions are sent in."""

    def __init__(self, node: Node, run: MethodRun, prefix: str) -> None:
        self.run = run
        self.torque_publisher = node.create_publisher(JointState, prefix + TORQUE, STREAM_QOS)
        self.external_publisher = node.create_publisher(JointState, prefix + EXTERNAL_TORQUE,
                                                        STREAM_QOS)
        self.contact_publisher = node.create_publisher(JointState, prefix + CONTACT,
                                                       CONTACT_QOS)
        self.mse_publisher = node.create_publisher(Float64MultiArray, prefix + MSE, 10)
        self.armed_publisher = node.create_publisher(Bool, prefix + CONTACT_ARMED, ARMED_QOS)
        self.armed: bool | None = None  # as last published
        # Serialized messages go straight to the publishers' handles: rclpy's
        # Publisher.publish checks the type and guards the handle on every call (a third
        # of a publication's CPU); this node publishes from its one thread while they live.
        self.send_torque: Callable[[bytes], None] = self.torque_publisher.handle.publish_raw
        self.send_external_torque: Callable[[bytes], None] = (
            self.external_publisher.handle.publish_raw)
        self.template: JointStateTemplate | None = None  # the predictions' message
        self.external_template: JointStateTemplate | None = None  # the external torques'
        self.send_external = True  # publish external_torque (parameter external_torque)
        self.deltas = Deltas()

    def publish_armed(self) -> None:
        """Publish ``contact_armed`` when it changes (and the first time)."""
        detector = self.run.detector
        armed = detector is not None and detector.armed
        if armed != self.armed:
            self.armed = armed
            self.armed_publisher.publish(Bool(data=armed))

    def publish(self, predictions: tuple[Prediction, ...], frame_id: str) -> None:
        """Publish the session's ``predictions`` of this method: each with its sample's q
        and q', its external torque (unless switched off) and, if some joints are over their
        threshold, a contact message naming them; stamped with its sample."""
        if not predictions:
            return
        template, external = self.template, self.external_template
        if template is None or template.frame_id != frame_id:
            names = self.run.lazy.names
            template = self.template = JointStateTemplate(names, frame_id, state=True)
            external = self.external_template = JointStateTemplate(names, frame_id)
        assert external is not None
        publish, send_external = self.send_torque, self.send_external
        for p in predictions:
            publish(template.fill(p.stamp_ns, p.effort, p.x))
            if p.external is None:
                continue
            if send_external:
                self.send_external_torque(external.fill(p.stamp_ns, p.external))
            contact = p.contact
            if contact is not None and contact.any():
                names = [name for name, hit in zip(external.names, contact) if hit]
                self.contact_publisher.publish(joint_state(
                    p.stamp_ns, names, effort=p.external[contact], frame_id=frame_id))

    def publish_mse(self, *, refresh: bool = True) -> bool:
        """Publish the windowed per-joint and overall MSE and NMSE; ``refresh`` False: with
        the validation score as it is. Return whether the held-out samples were scored."""
        core = self.run.core
        if core is None or core.errors.count == 0:
            return False
        scored = refresh and self.run.validation_stale
        dims, data = encode_mse(self.run.lazy.names, core.error_stats(),
                                self.run.validation(refresh=refresh))
        msg = Float64MultiArray(data=data)
        msg.layout.dim = [MultiArrayDimension(**dim._asdict()) for dim in dims]
        self.mse_publisher.publish(msg)
        return scored


class IdentifierNode(Node):
    """Subscribe ``joint_states``; publish a-priori torque predictions and their error."""

    def __init__(self) -> None:
        super().__init__('identifier')
        own = declare_parameters(self, (END_HISTORY_AFTER, REALTIME_PRIORITY, WAIT_FOR_NODES))
        # the parameters, converted once: replaced by the new settings when some are set
        self.settings = s = IdentifierSettings.of(
            declare_parameters(self, IDENTIFIER_PARAMETERS, on_change=self._apply))
        self.session = session = IdentificationSession(s, log=self.get_logger().info)
        for key in ('save_path', 'stats_file'):
            for path in session.paths[key].values():
                problem = unwritable_file(path) if path else ''
                if problem:
                    raise ConfigError(f'{key} {path}: {problem}')
        self.last_warning = 0.0
        self.outputs = [Outputs(self, run, f'{run.method}/' if session.several else '')
                        for run in session.runs]
        for out in self.outputs:
            out.send_external = s.external_torque
            out.publish_armed()
        if s.trainer == 'lm' and s.lm_background:
            prestart(len(self.outputs))  # their interpreters start now, not with the stream
        self.frame_id = ''  # header.frame_id of the latest sample, given to its predictions
        self.reader = JointStateReader()
        self.subscription: Subscription | None = None
        self.publisher_watch: PublisherWatch | None = None  # once subscribed
        self.mse_timer = self.create_timer(1.0 / s.mse_rate_hz, self.publish_mse)
        self.create_timer(STATS_PERIOD, self.log_stats)
        # contact calibration: every contact_calibration_period a round per method, done
        # in steps of CALIBRATION_SLICE held-out samples, one step every CALIBRATION_TICK
        self.calibration_queue: deque[Outputs] = deque()
        self.next_calibration = 0.0  # monotonic s
        self.create_timer(CALIBRATION_TICK, self.calibrate_contacts)
        self.checkpoint_timer: Timer | None = None
        self._start_checkpoints()
        # samples missing from the stream, from the stamps; longer jumps than the q''
        # estimate bridges are pauses (between recordings), counted apart
        self.loss = LossCounter(span_s=s.max_gap, pause_periods=GAP_PERIODS)
        self.path = PathDelays()  # arrival to publication of each sample's predictions
        self.last_sample: float | None = None  # monotonic s of the latest sample
        self.ended_history = True  # the pending samples are out since the latest sample
        self.end_history_after: float = own[END_HISTORY_AFTER.name]
        self.wait_for_nodes: list[str] = list(own[WAIT_FOR_NODES.name])
        if self.end_history_after > 0:
            self.create_timer(QUIET_TICK, self._end_quiet_history)
        self.diagnostics = [
            Diagnostics(self, f'{out.run.method} identification' if session.several
                        else 'identification', partial(self.health, out))
            for out in self.outputs]
        self.create_service(Trigger, '~/save_model', self.on_save_model)
        self.create_service(Trigger, '~/reset', self.on_reset)
        # Once built, the cores live as long as the node: frozen out of the collector's
        # sight as the node is (run_node), a full collection does not walk them while
        # samples wait (it did, for tens of ms).
        self.frozen_with_cores = False
        if s.wait_for_subscribers > 0:
            self.wait_deadline = time.monotonic() + s.wait_timeout
            self.wait_timer = self.create_timer(WAIT_POLL_PERIOD, self._subscribe_when_heard)
            self.get_logger().info(
                f'waiting for {s.wait_for_subscribers} subscriber(s)'
                + (f" ({', '.join(self.wait_for_nodes)})" if self.wait_for_nodes else '')
                + ' on ' + ', '.join(
                    f'{o.torque_publisher.topic_name} and {o.mse_publisher.topic_name}'
                    for o in self.outputs))
        else:
            self._subscribe()

    def _subscribe(self) -> None:
        """Subscribe ``joint_states``: from now on samples are processed."""
        # raw: the message is split in place (joint_state_cdr), not built as objects
        self.subscription = self.create_subscription(
            JointState, JOINT_STATES, self.on_raw_joint_state, INPUT_QOS, raw=True)
        self.publisher_watch = PublisherWatch(self, self.subscription.topic_name)
        outputs = ', '.join(o.torque_publisher.topic_name for o in self.outputs)
        self.get_logger().info(
            f"{'/'.join(o.run.method.upper() for o in self.outputs)} identifier on "
            f'{self.subscription.topic_name} → {outputs}, joints {self.session.joints_text}, '
            f"learning {'on' if self.settings.learn else 'off'}")

    def _subscribe_when_heard(self) -> None:
        """Timer: subscribe once every output has ``wait_for_subscribers`` subscribers, those
        of ``wait_for_nodes`` among them."""
        wanted = self.settings.wait_for_subscribers
        ready = all(subscribers_heard(self, publisher, wanted, self.wait_for_nodes)
                    for o in self.outputs for publisher in (o.torque_publisher, o.mse_publisher))
        if not ready and time.monotonic() < self.wait_deadline:
            return
        if not ready:
            heard = min(min(o.torque_publisher.get_subscription_count(),
                            o.mse_publisher.get_subscription_count())
                        for o in self.outputs)
            self.get_logger().warning(
                f'only {heard} of {wanted} subscribers on the outputs after '
                f'{self.settings.wait_timeout:g} s; subscribing anyway')
        self.wait_timer.cancel()
        self.destroy_timer(self.wait_timer)
        self._subscribe()

    # ------------------------------------------------------------------ while running
    def _apply(self, changed: dict[str, Any]) -> None:
        """Make parameters set while running take effect (they passed their checks)."""
        self.settings = s = self.settings.replace(**changed)
        self.get_logger().info('set ' + ', '.join(f'{k} = {v!r}' for k, v in changed.items()))
        self.session.apply(s, changed)
        for out in self.outputs:
            out.send_external = s.external_torque
            out.publish_armed()
        if 'mse_rate_hz' in changed:
            self.destroy_timer(self.mse_timer)
            self.mse_timer = self.create_timer(1.0 / s.mse_rate_hz, self.publish_mse)
        if 'checkpoint_period' in changed:
            self._start_checkpoints()

    def _start_checkpoints(self) -> None:
        """(Re)start the checkpoint timer for the current ``checkpoint_period``."""
        if self.checkpoint_timer is not None:
            self.destroy_timer(self.checkpoint_timer)
            self.checkpoint_timer = None
        if self.settings.save_path and self.settings.checkpoint_period > 0:
            self.checkpoint_timer = self.create_timer(self.settings.checkpoint_period,
                                                      self.checkpoint)

    def on_save_model(self, request: Trigger.Request,
                      response: Trigger.Response) -> Trigger.Response:
        """Service ``~/save_model``: save to ``save_path`` now, or say why not."""
        saved = [self.session.save(run) for run in self.session.runs]
        response.success = all(ok for ok, _ in saved)
        response.message = '; '.join(message for _, message in saved)
        self.get_logger().info(f'~/save_model: {response.message}')
        return response

    def on_reset(self, request: Trigger.Request, response: Trigger.Response
                 ) -> Trigger.Response:
        """Service ``~/reset``: start again from fresh weights (see
        :meth:`IdentificationSession.reset`)."""
        response.success, response.message, why = self.session.reset(stream=self.stream())
        if why:
            self._warn(why)
        for out in self.outputs:
            out.publish_armed()
        if response.success:
            self.get_logger().info(f'~/reset: {response.message}')
        return response

    def health(self, out: Outputs, period_s: float) -> Health:
        """A method's health over the last ``period_s`` s, for ``/diagnostics``."""
        figures = self.session.health_figures(out.run)
        self._settle_loss()
        recent = out.deltas(processed=figures.processed, skipped=figures.skipped.total,
                            lost=self.loss.lost)
        return identifier_health(
            period_s=period_s, since_sample_s=(None if self.last_sample is None
                                               else time.monotonic() - self.last_sample),
            lost=self.loss.lost, recent_processed=int(recent['processed']),
            recent_skipped=int(recent['skipped']), recent_lost=int(recent['lost']),
            **figures.as_dict())

    # ------------------------------------------------------------------ per sample
    def on_raw_joint_state(self, raw: bytes) -> None:
        """A serialized sample from ``joint_states``: see :meth:`on_sample`."""
        self.on_sample(self.reader.read(raw))

    def on_joint_state(self, msg: JointState) -> None:
        """A sample as a message object: see :meth:`on_sample`."""
        self.on_sample(JointStateReader.of_message(msg))

    def on_sample(self, msg: RawJointState) -> None:
        """Check and differentiate once; predict, publish, learn for each method."""
        self.last_sample = time.monotonic()
        self.ended_history = False
        stamp_ns, now_ns = msg.stamp_ns, time.time_ns()
        self.path.arrived(stamp_ns, now_ns)
        assert self.publisher_watch is not None  # subscribed
        self.publisher_watch.stamps.observe(stamp_ns)
        outcome = self.session.process(
            stamp_ns, msg.names, msg.position, msg.velocity, msg.effort, arrived_ns=now_ns,
            restart=self.loss.observe(stamp_ns))
        if self.session.core is not None:
            self.frame_id = msg.frame_id
            if not self.frozen_with_cores:
                self.frozen_with_cores = True
                gc.freeze()
        for out, predictions in zip(self.outputs, outcome.predictions):
            out.publish(predictions, self.frame_id)
        inputs = outcome.inputs
        if inputs:
            self.path.out(inputs[0].stamp_ns, inputs[-1].stamp_ns, time.time_ns())
        for text in outcome.warnings:
            self._warn(text)

    def _warn(self, text: str) -> None:
        now = time.monotonic()
        if now - self.last_warning >= WARN_PERIOD:
            self.last_warning = now
            self.get_logger().warning(text)

    # ------------------------------------------------------------------ periodic
    def calibrate_contacts(self) -> None:
        """Timer: one step of the contact calibration (a round for each method every
        ``contact_calibration_period``), publishing ``contact_armed`` where a round changed
        it. A step predicts at most :data:`CALIBRATION_SLICE` held-out samples, or fits the
        thresholds: the message path waits for no more than that."""
        queue, now = self.calibration_queue, time.monotonic()
        if not queue and now >= self.next_calibration:
            queue.extend(self.outputs)
            self.next_calibration = now + self.settings.contact_calibration_period
        if not queue:
            return
        out = queue[0]
        period_ns = self.loss.period_ns
        out.run.calibrate_contacts(period_ns / 1e9 if period_ns else DEFAULT_PERIOD,
                                   budget=CALIBRATION_SLICE)
        if not out.run.calibrating:
            queue.popleft()
            out.publish_armed()

    def publish_mse(self) -> None:
        """Publish each method's windowed per-joint and overall MSE and NMSE; at most one
        method's held-out samples are scored per call (the others' on the next calls), so
        that the message path does not wait for all of them at once."""
        scored = False
        for out in self.outputs:
            scored |= out.publish_mse(refresh=not scored)

    def handled(self) -> int:
        """Samples taken from ``joint_states`` so far (a stop drains until it stays put)."""
        return self.session.processed()

    def _end_quiet_history(self) -> None:
        """Once no sample has come for ``end_history_after`` s (and more than ``max_gap``
        and GAP_PERIODS sample periods: a stream whose stamps follow the clock would restart
        its history at the next sample anyway), predict (and learn) the pending samples as
        on stop and publish their predictions; the next sample starts a new history."""
        if self.ended_history or self.last_sample is None:
            return
        period_ns = self.loss.period_ns
        quiet = max(self.end_history_after, self.settings.max_gap,
                    GAP_PERIODS * (period_ns / 1e9 if period_ns else DEFAULT_PERIOD))
        if time.monotonic() - self.last_sample <= quiet:
            return
        self.ended_history = True
        outcome = self.session.flush()
        for out, predictions in zip(self.outputs, outcome.predictions):
            out.publish(predictions, self.frame_id)

    def _settle_loss(self) -> None:
        """Count the samples a long stamp step may have lost once the stream has paused (no
        sample for :data:`SETTLE_LOSS_S`): late samples would have come by then."""
        if self.last_sample is not None and time.monotonic() - self.last_sample > SETTLE_LOSS_S:
            self.loss.settle()

    def stream(self) -> StreamFigures:
        """Figures of the ``joint_states`` stream: losses, pauses, delays, publishers."""
        watch = self.publisher_watch
        self._settle_loss()
        return StreamFigures(
            lost=self.loss.lost, pauses=self.loss.pauses, paused_s=self.loss.paused_s,
            path_delay_p50_ms=self.path.delays.percentile_ms(50),
            path_delay_p99_ms=self.path.delays.percentile_ms(99),
            wall_clock_stamps=self.session.clock.wall,
            joint_states_publishers=watch.most_publishers if watch else 0,
            stamps_backward=watch.stamps.backward if watch else 0)

    def summary(self, run: MethodRun | None = None, *, fresh: bool = False) -> MethodReport:
        """A method's counters and errors so far (the first method's by default), with the
        stream's figures; ``fresh``: score the held-out samples now."""
        return self.session.summary(run, fresh=fresh, stream=self.stream())

    def log_stats(self) -> None:
        """Log counters, skipped samples by reason, lag, learning and the windowed error."""
        for run in self.session.runs:
            self._log_report(run, self.session.summary(run))
            run.line_lag_ns = 0

    def _log_report(self, run: MethodRun, report: MethodReport) -> None:
        """One statistics line of a method's report (none before any sample)."""
        who = f'{run.method}: ' if self.session.several else ''
        if not report.processed:
            return
        if run.core is None:  # no model yet
            self.get_logger().info(f'{who}processed {report.processed}, no valid sample '
                                   f'yet: skipped {report.skipped}')
            return
        extra = f', {report.no_effort} without effort' if report.no_effort else ''
        # steps refused by the trainer (not finite, or undone by bp's guard, which also
        # halves the learning rate) and predictions clipped to the effort limits
        extra += ''.join(f', {key} {n}' for key, n in (('refused', report.refused),
                                                      ('clipped', report.clipped)) if n)
        learning = report.learning
        if learning is not None and learning.updates_per_s is not None:
            extra += (f', {learning.updates} updates ({learning.updates_per_s:.1f}/s)'
                      + (f', {learning.learn_dropped} not learnt (learner behind)'
                         if learning.learn_dropped else ''))
        def number(value: float | None) -> float:
            return np.nan if value is None else value

        self.get_logger().info(
            f'{who}processed {report.processed}, learnt {report.learnt}, held out '
            f'{report.held_out}{extra}, skipped {report.skipped.total} ({report.skipped}), '
            f'worst lag since the last line {run.line_lag_ns / 1e6:.2f} ms, windowed MSE '
            f'{number(report.mse_total):.4g}, NMSE {number(report.nmse_total):.4g}, '
            f'validation NMSE {number(report.validation_nmse_total):.4g}')

    def checkpoint(self) -> None:
        """Save each model to its ``save_path``, if there is one; a failure is logged."""
        if not self.settings.save_path:
            return
        for run in self.session.runs:
            if run.core is not None:
                saved, message = self.session.save(run)
                if not saved:
                    self.get_logger().error(f'checkpoint: {message}')

    def close(self) -> None:
        """On shutdown: predict and learn the pending samples, wait (at most
        :data:`FLUSH_TIMEOUT`) until subscribers acknowledge them, take the learners' last
        weights, checkpoint and log the final statistics."""
        outcome = self.session.flush()
        for out, predictions in zip(self.outputs, outcome.predictions):
            out.publish(predictions, self.frame_id)
        if outcome.inputs:
            for out in self.outputs:
                for publisher in (out.torque_publisher, out.external_publisher,
                                  out.contact_publisher):
                    publisher.wait_for_all_acked(Duration(seconds=FLUSH_TIMEOUT))
        self.session.close()
        self.checkpoint()
        self.log_stats()
        for run in self.session.runs:
            stats_file = self.session.paths['stats_file'][run.method]
            if stats_file:
                Path(stats_file).parent.mkdir(parents=True, exist_ok=True)
                Path(stats_file).write_text(json.dumps(
                    self.summary(run, fresh=True).as_dict(), indent=1))


def main(args: list[str] | None = None) -> None:
    """Console script ``identifier``."""
    # One BLAS thread: the lm trainer's steps (684 unknowns) gain nothing from a second one,
    # and competing BLAS pools slow them down on a busy machine (docs/results.md).
    with single_blas_thread():
        status = run_node('identifier', IdentifierNode, args, description=__doc__ or '',
                          parameters=PARAMETERS)
    sys.exit(status)


if __name__ == '__main__':
    main()
