"""An identification session: one or several methods learning from one joint-state stream.

What the ``identifier`` node does between its messages, without ROS: the joint limits and
the robot's URDF its parameters name, each method's warm start (``model_path``, else a
model already at ``save_path``), the cores, built for the joints of ``joint_names`` or of
the first valid sample and sharing one input stage (each sample is checked and
differentiated once, then every method predicts and learns it), parameters changed while
running, ``~/reset`` with the summaries of before kept, saving, and the summary of counters
and errors a stats file holds. :class:`MethodRun` is one method's part: its core, contact
detector, held-out score and lag figures.

The path is one way: :meth:`IdentificationSession.process` returns, per method, each
prediction with its external torque, contact flags and lag
(:class:`~scara_ident_ros.identification.sample_outcome.SampleOutcome`), and the node only
publishes them; the contact thresholds change only in the explicit step
:meth:`MethodRun.calibrate_contacts`.

``settings`` are the node's parameters, typed
(:class:`~scara_ident_ros.identification.identifier_settings.IdentifierSettings`).
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Collection, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES, load_joint_limits
from scara_ident_ros.dynamics.urdf_limits import UrdfError, parse_urdf
from scara_ident_ros.errors import ConfigError
from scara_ident_ros.estimator import Estimator, load_model
from scara_ident_ros.identification.background_lm import BackgroundLM
from scara_ident_ros.identification.contact_detector import (A_PRIORI, Calibration,
                                                             ContactDetector)
from scara_ident_ros.identification.differentiator import (AccelerationEstimate,
                                                           make_differentiator)
from scara_ident_ros.identification.error_window import ErrorWindow
from scara_ident_ros.identification.identifier_builder import background_learner
from scara_ident_ros.identification.input_stage import Input, InputStage
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.lazy_core import UNSCALED_METHODS, LazyCore
from scara_ident_ros.identification.learner_process import LearnerClient
from scara_ident_ros.identification.metrics import ErrorStats
from scara_ident_ros.identification.online_identifier import OnlineIdentifier, StepResult
from scara_ident_ros.identification.reports import (ContactState, HealthFigures,
                                                    LearningFigures, MethodReport, SkipCounts,
                                                    StreamFigures)
from scara_ident_ros.identification.skip_reason import SkipReason
from scara_ident_ros.identification.stream_clock import LagHistogram, StreamClock
from scara_ident_ros.identification.reservoir_lm import ReservoirLM
from scara_ident_ros.identification.sample_outcome import Prediction, SampleOutcome
from scara_ident_ros.identification.warm_start import check_warm_start
from scara_ident_ros.nn import ModelFormatError
from scara_ident_ros.nn.presets import METHODS

__all__ = ['CONTACT_PARAMETERS', 'JOINT_SET_REASONS', 'METHOD_FIELD', 'PATH_PARAMETERS',
           'VALIDATION_PERIOD', 'IdentificationSession', 'MethodRun', 'contact_detector',
           'method_path']

METHOD_FIELD = '{method}'  # stands for each method in a path parameter, with methods
PATH_PARAMETERS = ('save_path', 'stats_file', 'model_path')
VALIDATION_PERIOD = 1.0  # s: the held-out score is recomputed at most this often per method
CONTACT_PARAMETERS = {'contact_sigma', 'contact_arm_nmse', 'contact_min_samples',
                      'contact_false_alarms_per_hour', 'contact_envelope_margin',
                      'contact_envelope_acceleration', 'contact_calibration',
                      'contact_calibration_window'}
#: Rejections that mean the message's joints are not the identifier's
JOINT_SET_REASONS = (SkipReason.UNKNOWN_JOINT, SkipReason.MISSING_JOINT,
                     SkipReason.DUPLICATE_JOINT, SkipReason.JOINT_COUNT)


def method_path(path: str, method: str) -> str:
    """``path`` for ``method``: ``{method}`` in it replaced by the method's name."""
    return path.replace(METHOD_FIELD, method)


def _set_step(model: Estimator, learning_rate: float | None, momentum: float | None
              ) -> None:
    """Set the per-sample step's learning rate and momentum of a model that has one (a
    network; not a physical model nor a hybrid); None leaves one as it is."""
    for key, value in (('learning_rate', learning_rate), ('momentum', momentum)):
        if value is not None and hasattr(model, key):
            setattr(model, key, value)


def contact_detector(n_joints: int, settings: IdentifierSettings) -> ContactDetector:
    """A fresh (unarmed) contact detector of ``n_joints`` of the ``contact_*`` settings."""
    return ContactDetector(
        n_joints, sigma=settings.contact_sigma, arm_nmse=settings.contact_arm_nmse,
        min_samples=settings.contact_min_samples,
        false_alarms_per_hour=settings.contact_false_alarms_per_hour,
        envelope_margin=settings.contact_envelope_margin,
        envelope_acceleration=settings.contact_envelope_acceleration,
        calibrate_on=settings.contact_calibration,
        recent_s=settings.contact_calibration_window)


class _Round:
    """A calibration under way: the held-out segments as they were at its start (inputs
    (K, L, 3n), efforts (K, L, n), blocks (K,)), their residuals as far as predicted."""

    def __init__(self, X: NDArray[np.float64], Y: NDArray[np.float64],
                 blocks: NDArray[np.int64]) -> None:
        self.X, self.Y, self.blocks = X, Y, blocks
        self.residuals = np.empty_like(Y)
        self.done = 0  # segments predicted


class MethodRun:
    """One method (of ``parameters.ONLINE_METHODS``) in a session: its ``lazy`` core, a
    contact detector of the ``contact_*`` ``settings``, its held-out score and lag figures.

    The held-out score is a cached reading (:meth:`validation`); the contact thresholds
    change only in the explicit step :meth:`calibrate_contacts`."""

    def __init__(self, method: str, lazy: LazyCore, settings: IdentifierSettings) -> None:
        self.method = method
        self.lazy = lazy
        self.settings = settings  # the session's, as of the last apply
        self.detector: ContactDetector | None = None  # once the joints are known
        self.contacts = 0  # samples with a joint over its contact threshold
        self.line_lag_ns = 0  # ns, largest since the last statistics line
        self.worst_lag_ns = 0  # ns, since start
        self.period_lag_ns = 0  # ns, largest since the last diagnostics report
        self.lags = LagHistogram()  # every prediction's lag, for percentiles
        self.decisions = LagHistogram()  # every contact decision's delay from its stamp
        self.period_decisions = LagHistogram()  # since the last diagnostics report
        self.previous: list[MethodReport] = []  # reports from before each reset
        self._validation: ErrorStats | None = None
        self._validated_at = -math.inf  # monotonic s
        self._round: _Round | None = None  # a calibration under way

    @property
    def core(self) -> OnlineIdentifier | None:
        """The online core, once the joints are known."""
        return self.lazy.core

    @property
    def network(self) -> Estimator | None:
        """The model: the core's once built (a kernel learner's streamed model), else a
        warm start."""
        core = self.lazy.core
        return core.model if core is not None else self.lazy.network

    @property
    def background(self) -> LearnerClient | None:
        """The trainer, if it learns beside the stream (a hybrid's: its network's)."""
        return background_learner(self.core.trainer if self.core is not None else None)

    def built(self, names: Sequence[str]) -> None:
        """The core is built for ``names``: a disarmed contact detector, no score yet."""
        self.detector = contact_detector(len(names), self.settings)
        self._validation, self._validated_at = None, -math.inf
        self._round = None

    @property
    def validation_stale(self) -> bool:
        """Whether :meth:`validation` would score the held-out samples now."""
        return self.core is not None and (
            self._validation is None
            or time.monotonic() - self._validated_at >= VALIDATION_PERIOD)

    def validation(self, *, fresh: bool = False, refresh: bool = True) -> ErrorStats | None:
        """The held-out score, recomputed at most every :data:`VALIDATION_PERIOD` s once
        there is one (scoring the whole held-out set at the error topic's rate would load
        the message path); until then, while there are few held-out samples, each time;
        ``refresh`` False: the score as it is (a caller spreading the methods' scoring over
        its calls). A fresh score at or over ``contact_arm_nmse`` disarms contact detection
        (a model that got worse since its calibration); the thresholds change only in
        :meth:`calibrate_contacts`."""
        if self.core is not None and (fresh or (refresh and self.validation_stale)):
            self._validation = self.core.validation_stats()
            self._validated_at = time.monotonic()
            if self._validation is not None and self.detector is not None:
                self.detector.update_nmse(float(self._validation.nmse_total))
        return self._validation

    def calibrate_contacts(self, sample_period_s: float, *, budget: int | None = None
                           ) -> Calibration | None:
        """The explicit calibration step: the residuals the checks kept (a-priori, at once)
        or the current model's on the held-out segments, and a fresh validation score, set
        the contact thresholds and arm or disarm detection; ``sample_period_s`` is the
        stream's (s).

        ``budget``, held out: samples to predict in this call (a round's segments are copied
        at its start, predicted over several calls, then the detector calibrated in a call
        of its own), so that no call holds the message path long; None: all at once.
        Returns the :class:`Calibration` when a round ends, else None (also before the
        core exists).
        """
        core, detector = self.core, self.detector
        if core is None or detector is None:
            return None
        segments = core.holdout.segments if core.holdout is not None else None
        if self._round is None and detector.calibrate_on == A_PRIORI:
            # the residuals are those the checks kept; the held-out segments give only
            # their inputs (the envelope): nothing to predict
            validation = self.validation(fresh=True)
            return detector.calibrate(
                None, None if validation is None else float(validation.nmse_total),
                inputs=None if segments is None or len(segments) == 0 else segments.X,
                sample_period_s=sample_period_s)
        if self._round is None:
            if segments is None or len(segments) == 0:
                validation = self.validation(fresh=True)
                return detector.calibrate(
                    None, None if validation is None else float(validation.nmse_total))
            self._round = _Round(segments.X.copy(), segments.Y.copy(),
                                 segments.blocks.copy())
            if budget is not None:
                return None
        rnd = self._round
        n_in = rnd.X.shape[-1]
        while rnd.done < len(rnd.X) and (budget is None or budget > 0):
            step = len(rnd.X) - rnd.done if budget is None else max(
                1, budget // rnd.X.shape[1])
            part = slice(rnd.done, min(rnd.done + step, len(rnd.X)))
            X = rnd.X[part]
            rnd.residuals[part] = rnd.Y[part] - np.asarray(
                core.model.predict(X.reshape(-1, n_in))).reshape(rnd.Y[part].shape)
            rnd.done = part.stop
            if budget is not None:
                return None
        self._round = None
        validation = self.validation(fresh=True)
        nmse = None if validation is None else float(validation.nmse_total)
        return detector.calibrate(rnd.residuals, nmse, inputs=rnd.X,
                                  sample_period_s=sample_period_s, blocks=rnd.blocks)

    @property
    def calibrating(self) -> bool:
        """Whether a calibration round is under way (:meth:`calibrate_contacts`)."""
        return self._round is not None

    def predictions(self, results: Sequence[StepResult], inputs: Sequence[Input],
                    lag: Callable[[int], int] | None) -> tuple[Prediction, ...]:
        """The core's ``results`` for ``inputs`` (one input per result with a prediction,
        in order) as what is published: each with its external torque and contact flags
        (:meth:`check_contact`, against the sample's input for the envelope) and its lag,
        ``lag(stamp_ns)`` (ns; recorded with the contact decision's delay; None on
        shutdown: not recorded)."""
        out = []
        samples = iter(inputs)
        for result in results:
            effort = result.effort
            if effort is None:  # a rejection: no prediction
                continue
            x = next(samples).x
            measured = result.measured
            lag_ns = None if lag is None else lag(result.stamp_ns)
            external = contact = None
            if measured is not None:
                external = measured - effort
                contact = self.check_contact(external, x)
                if lag_ns is not None:
                    self.record_decision(lag_ns)
            if lag_ns is not None:
                self.record_lag(lag_ns)
            out.append(Prediction(result.stamp_ns, effort, x, result.held_out, measured,
                                  external, contact, lag_ns))
        return tuple(out)

    def record_lag(self, lag_ns: int) -> None:
        """Take how late (ns) a prediction was ready to publish, against its stamp."""
        self.lags.add(lag_ns)
        self.period_lag_ns = max(self.period_lag_ns, lag_ns)
        if lag_ns > self.line_lag_ns:
            self.line_lag_ns = lag_ns
            self.worst_lag_ns = max(self.worst_lag_ns, lag_ns)

    def check_contact(self, torque: NDArray[np.float64],
                      x: NDArray[np.float64] | None = None) -> NDArray[np.bool_]:
        """Which joints of a sample's external torque (n,) (N·m or N) are over their
        contact threshold, given its input x = [q, q', q''] (3n,) (the envelope); a sample
        with any counts as a contact."""
        assert self.detector is not None  # built with the core
        over = self.detector.check(torque, x)
        if over.any():
            self.contacts += 1
        return over

    def record_decision(self, delay_ns: int) -> None:
        """Take how late (ns, from the sample's stamp) a contact decision was made."""
        self.decisions.add(delay_ns)
        self.period_decisions.add(delay_ns)

    def contact_health(self) -> ContactState:
        """Contact detection's state: armed, why not, the thresholds (N·m or N), the
        estimated false alarms per hour, the independent held-out segments, samples held
        outside the calibrated envelope, and the decision delay p50/p99 (ms) since the last
        call."""
        detector = self.detector
        period, self.period_decisions = self.period_decisions, LagHistogram()
        if detector is None:
            return ContactState(why_not='no model yet')
        c = detector.calibration
        return ContactState(armed=detector.armed, why_not=c.why_not,
                            thresholds=MethodReport.per_joint(c.thresholds),
                            false_alarms_per_hour=c.false_alarms_per_hour,
                            segments=c.independent, held=detector.held,
                            delay_p50_ms=period.percentile_ms(50),
                            delay_p99_ms=period.percentile_ms(99))

    def learning(self) -> LearningFigures | None:
        """How learning progresses: updates and their rate for a trainer beside the
        stream; None for a trainer in the message path."""
        background = self.background
        if background is None:
            return None
        return LearningFigures(updates=background.updates, updates_per_s=background.rate(),
                               lm_steps_taken=background.steps_taken,
                               learn_dropped=background.dropped)

    def apply(self, settings: IdentifierSettings, changed: Collection[str]) -> None:
        """Make parameters set while running take effect: ``settings`` now, of which the
        parameters named ``changed`` were set. A change of the contact settings makes a
        new, unarmed detector until the next :meth:`calibrate_contacts`."""
        self.settings = s = settings
        network, core = self.network, self.core
        if network is not None and self.method in METHODS:
            preset = METHODS[self.method]
            _set_step(network,
                      (s.learning_rate or preset.learning_rate
                       if 'learning_rate' in changed else None),
                      ((s.momentum if s.momentum >= 0 else preset.momentum)
                       if 'momentum' in changed else None))
        if CONTACT_PARAMETERS & set(changed) and self.detector is not None:
            previous, self.detector = self.detector, contact_detector(self.detector.n_joints, s)
            self.detector.keep_recent(previous)  # the same model's residuals
        if core is None:
            return
        core.learn = s.learn
        core.stage.check.need_effort = s.learn  # predict-only takes any sample
        if 'mse_window' in changed:
            core.errors = ErrorWindow(core.n_joints, s.mse_window)
        trainer = core.trainer
        if isinstance(trainer, ReservoirLM):
            trainer.lm_interval = s.lm_interval
            trainer.lm_steps = s.lm_steps
        elif isinstance(trainer, BackgroundLM) and {'lm_interval', 'lm_steps'} & set(changed):
            trainer.set_schedule(lm_interval=s.lm_interval, lm_steps=s.lm_steps)


class IdentificationSession:
    """The methods of one identifier, their warm starts and cores (module docstring).

    ``settings`` are kept, and replaced by :meth:`apply` when parameters are set while
    running. ``log(text)`` takes what is worth an info line. Bad settings
    raise ConfigError, LimitsError, UrdfError or ParamError, one line naming the parameter.
    """

    def __init__(self, settings: IdentifierSettings, *,
                 log: Callable[[str], None] | None = None) -> None:
        s = self.settings = settings
        self.log = log or (lambda text: None)
        self.limits = load_joint_limits(
            joint_names=s.joint_names, robot_config=s.robot_config, urdf_file=s.urdf_file,
            robot_description=s.robot_description,
            explicit={key: getattr(s, key) for key in LIMIT_NAMES}, partial=True)
        methods = list(s.methods) or [s.method]
        self.urdf = self._urdf()
        # what the stream completes: the URDF's joints without acceleration (or any) limits
        urdf_limits = parse_urdf(self.urdf[0], source=self.urdf[1]) if self.urdf[0] else None
        if len(set(methods)) != len(methods):
            raise ConfigError(f'methods names a method twice: {methods}')
        self.several = len(s.methods) > 0
        paths = {key: str(getattr(s, key)) for key in PATH_PARAMETERS}
        for key, path in paths.items():
            if self.several and path and METHOD_FIELD not in path:
                raise ConfigError(f'{key} {path}: with methods, the path needs '
                                  f'{METHOD_FIELD} (one file per method)')
        self.paths = {key: {m: method_path(path, m) for m in methods}
                      for key, path in paths.items()}
        names = list(s.joint_names)
        self.runs: list[MethodRun] = []
        for method in methods:
            network, names = self._warm_start(method, names, log)
            self.runs.append(MethodRun(
                method, LazyCore(self.limits, network, urdf=self.urdf[0],
                                 urdf_source=self.urdf[1], urdf_limits=urdf_limits),
                s))
        # the method whose core is built from the first valid sample and, where the files lack
        # limits, completes them from the stream for all: the first that is scaled by them
        # (a learner or the physical model first would build at once and leave the others
        # waiting for limits nobody collects)
        self.lead = next((run for run in self.runs if run.method not in UNSCALED_METHODS),
                         self.runs[0])
        # checked at start (a bad window ends it in one line), used once the joints are known
        self.differentiator = self._differentiator()
        self.clock = StreamClock()  # the lags, against the stream's own clock
        #: the stream's one input stage (checks, q'' estimate), made with the first core built
        #: and given to every other: each sample is checked and differentiated once
        self.stage: InputStage | None = None
        missing_limits = self._build(names) if names else ''
        if missing_limits:
            raise ConfigError(f'joint_names: {missing_limits}')
        if self.core is not None:
            self.log(self.first.lazy.limits_note)
        self.joints_text = str(names or '(from the first message)')

    # ------------------------------------------------------------------ the first method
    @property
    def first(self) -> MethodRun:
        """The first (or only) method."""
        return self.runs[0]

    @property
    def core(self) -> OnlineIdentifier | None:
        """The first method's online core, once the joints are known."""
        return self.first.core

    @property
    def network(self) -> Estimator | None:
        """The first method's model: a warm start, or built with the core."""
        return self.first.network

    @property
    def names(self) -> list[str]:
        """The identified joints, once the cores are built."""
        return self.lead.lazy.names

    def processed(self) -> int:
        """Samples taken so far."""
        return self.lead.lazy.counts.processed

    # ------------------------------------------------------------------ warm start
    def model_source(self, method: str) -> str:
        """Where ``method``'s warm start comes from: model_path, else a model at save_path
        (a restart continues from what was learnt instead of replacing it), else ''."""
        model_path = self.paths['model_path'][method]
        save_path = self.paths['save_path'][method]
        if not model_path and save_path and Path(save_path).exists():
            return save_path
        return model_path

    def _warm_start(self, method: str, names: list[str], log: Callable[[str], None] | None
                    ) -> tuple[Estimator | None, list[str]]:
        """``method``'s warm start, if any, and the joints it fixes."""
        source = self.model_source(method)
        if not source:
            return None, names
        network = self._load(source)
        names = check_warm_start(network, names, source=source, method=method)
        if source != self.paths['model_path'][method] and log is not None:
            log(f'{method}: continuing from the model at save_path {source}')
        return network, names

    def _load(self, path: str) -> Estimator:
        """The model file at ``path``, of the kind it holds, with the online step's
        ``learning_rate`` and ``momentum`` if set (and the model has them)."""
        try:
            network = load_model(path)
        except (ModelFormatError, UrdfError, OSError) as exc:
            raise ConfigError(f'cannot warm-start: {exc}') from None
        s = self.settings
        _set_step(network, s.learning_rate if s.learning_rate > 0 else None,
                  s.momentum if s.momentum >= 0 else None)
        return network

    def _urdf(self) -> tuple[str, str]:
        """The robot's URDF (text) and its source, from robot_description or urdf_file."""
        s = self.settings
        if s.robot_description:
            return s.robot_description, 'robot_description'
        if s.urdf_file:
            try:
                return Path(s.urdf_file).read_text(encoding='utf-8'), s.urdf_file
            except (OSError, UnicodeDecodeError) as exc:
                raise ConfigError(f'urdf_file {s.urdf_file}: cannot read it: {exc}'
                                  ) from None
        return '', ''

    # ------------------------------------------------------------------ building
    def _differentiator(self) -> AccelerationEstimate:
        s = self.settings
        return make_differentiator(s.differentiator, window=s.window, cutoff_hz=s.cutoff_hz)

    def _core_settings(self, method: str) -> IdentifierSettings:
        return self.settings.replace(method=method)

    def _build(self, names: list[str], runs: Sequence[MethodRun] | None = None) -> str:
        """Build the cores of ``runs`` (all by default: with a fresh input stage) for
        ``names``, sharing the session's input stage; return '' or why not (a joint without
        limits)."""
        stage = self.stage if runs is not None else None
        if any(run.lazy.needs_stream(names, run.method) for run in self.runs):
            return ''  # built from the first samples, which complete the limits
        for run in self.runs if runs is None else runs:
            why = run.lazy.build(names, self._core_settings(run.method), self.differentiator,
                                 stage=stage, background=self.settings.lm_background)
            if why:
                return why
            assert run.core is not None
            stage = self.stage = run.core.stage
            run.built(names)
        return ''

    def _build_from(self, stamp_ns: int, names: tuple[str, ...] | list[str], position: Any,
                    velocity: Any, effort: Any) -> list[str]:
        """Build for the joints of a sample if it is valid; else count it as skipped.
        Return the warnings (none when built)."""
        first = self.lead.lazy
        skipped = first.first(self._core_settings(self.lead.method), self.differentiator,
                              stamp_ns, names, position, velocity, effort,
                              background=self.settings.lm_background,
                              wanted=self.settings.joint_names)
        if skipped is not None and skipped.reason is None:  # kept to complete the limits
            if skipped.note:
                self.log(skipped.note)
            return []
        if skipped is None:
            assert self.lead.core is not None
            self.stage = self.lead.core.stage
            self.log(first.limits_note)
            others = [run for run in self.runs if run is not self.lead]
            for run in others:
                run.lazy.adopt_limits(first)
                run.lazy.early = dataclasses.replace(first.early,
                                                     skipped=dict(first.early.skipped))
            why = self._build(self.names, others)
            if why:
                return [why]
            self.lead.built(self.names)
            return []
        warnings = [skipped.note] if skipped.note else []
        reason = skipped.reason
        assert reason is not None
        return warnings + [f'skipped a sample ({reason.value}) before the first valid one']

    # ------------------------------------------------------------------ per sample
    def process(self, stamp_ns: int, names: tuple[str, ...] | list[str], position: Any,
                velocity: Any, effort: Any, *, arrived_ns: int | None = None,
                restart: bool = False) -> SampleOutcome:
        """Check and differentiate a sample once; predict and learn for each method.

        Parameters
        ----------
        stamp_ns : int
            The sample's stamp (ns).
        names : sequence of str of length m
            Its joint names, in message order.
        position, velocity, effort : array_like of shape (m,) or (0,)
            q (rad, m), q' (rad/s, m/s) and efforts (N·m, N), each may be empty.
        arrived_ns : int, optional
            Wall time (ns) the sample arrived, for the lags; by default now.
        restart : bool
            The sample follows a pause or a restarted clock (the lags' offset starts anew).

        Returns
        -------
        SampleOutcome
            For each method in order, the predictions now due with all that is published of
            them; the samples they are of; why this sample was skipped, if it was.
        """
        self.clock.arrived(stamp_ns, time.time_ns() if arrived_ns is None else arrived_ns,
                           restart=restart)
        return self._process(stamp_ns, names, position, velocity, effort)

    def _process(self, stamp_ns: int, names: tuple[str, ...] | list[str], position: Any,
                 velocity: Any, effort: Any) -> SampleOutcome:
        """:meth:`process` a sample whose arrival the clock has taken."""
        if self.lead.core is None:
            warnings = self._build_from(stamp_ns, names, position, velocity, effort)
            if self.lead.core is None or warnings:
                return SampleOutcome.nothing(len(self.runs), tuple(warnings))
            replay = self.lead.lazy.take_replay()  # samples that completed the limits
            if len(replay) > 1:
                return self._replay(replay)
        core, stage = self.lead.core, self.stage
        assert stage is not None  # made with the cores
        reason, inputs = stage.push(stamp_ns, names, position, velocity, effort)
        results = []
        for run in self.runs:
            assert run.core is not None
            results.append(run.core.take(stamp_ns, reason, inputs))
        now_ns, clock = time.time_ns(), self.clock

        def lag(stamp: int) -> int:
            return clock.lag_ns(stamp, now_ns)

        predictions = tuple(run.predictions(mine, inputs, lag)
                            for run, mine in zip(self.runs, results))
        if reason is None or reason is SkipReason.WARMING_UP:
            return SampleOutcome(predictions, tuple(inputs), reason)
        if reason in JOINT_SET_REASONS:
            why = (f'skipped a sample ({reason.value}): it names joints {list(names)}, the '
                   f'identifier identifies {self.names} (set joint_names, or min_joints to '
                   'wait for a message naming them all)')
        else:
            why = f'skipped a sample ({reason.value}); {sum(core.counts.skipped.values())} so far'
        return SampleOutcome(predictions, tuple(inputs), reason, (why,))

    def _replay(self, samples: Sequence[Any]) -> SampleOutcome:
        """:meth:`process` the samples kept while the stream completed the limits (of
        :class:`~scara_ident_ros.identification.lazy_core.RawSample`), at once; the
        outcome of all, the last one's skip reason, the first warning."""
        predictions: list[tuple[Prediction, ...]] = [() for _ in self.runs]
        inputs: tuple[Input, ...] = ()
        warnings: tuple[str, ...] = ()
        skipped = None
        for sample in samples:
            outcome = self._process(*sample)
            predictions = [mine + theirs
                           for mine, theirs in zip(predictions, outcome.predictions)]
            inputs += outcome.inputs
            warnings += outcome.warnings
            skipped = outcome.skipped
        return SampleOutcome(tuple(predictions), inputs, skipped, warnings[:1])

    def flush(self) -> SampleOutcome:
        """On shutdown: the pending samples' predictions for each method (without lags)."""
        if self.lead.core is None or self.stage is None:
            return SampleOutcome.nothing(len(self.runs))
        inputs = self.stage.flush()
        predictions = []
        for run in self.runs:
            assert run.core is not None
            results = run.core.take(0, None, inputs, pushed=False)
            predictions.append(run.predictions(results, inputs, None))
        return SampleOutcome(tuple(predictions), tuple(inputs))

    # ------------------------------------------------------------------ while running
    def apply(self, settings: IdentifierSettings, changed: Collection[str] | None = None
              ) -> None:
        """Make parameters set while running take effect: ``settings`` now, of which the
        parameters named ``changed`` were set (None: those whose values differ)."""
        if changed is None:
            old = self.settings.as_dict()
            changed = {name for name, value in settings.as_dict().items()
                       if old[name] != value}
        self.settings = settings
        for run in self.runs:
            run.apply(settings, changed)

    def reset(self, *, stream: StreamFigures | None = None) -> tuple[bool, str, str]:
        """Start again from fresh weights, the summaries of before (with the ``stream``
        figures of :meth:`summary`) kept in ``previous``.

        Return success (False without a model yet), what was reset with each method's
        figures of before, and '' or why the cores could not be built again (a warm start's
        joints without limits: the next sample tries again).
        """
        names = self.names if self.core is not None else None
        if names is None and self.network is None:
            return False, 'nothing to reset: no model yet (no valid sample so far)', ''
        befores = []
        for run in self.runs:
            # each reset's own counters, one entry per reset
            before = dataclasses.replace(self.summary(run, stream=stream), previous=())
            run.previous.append(before)
            befores.append(before)
            run.lazy.reset()
        self.differentiator, self.stage = self._differentiator(), None
        why = self._build(names) if names is not None else ''
        message = f'fresh weights (seed {self.settings.seed}); before the reset: ' + '; '.join(
            f'{before.method}: processed {before.processed}, learnt {before.learnt}, '
            f'validation NMSE {before.validation_nmse_total}' for before in befores)
        return True, message, why

    def close(self) -> None:
        """Take the learners' last weights and stop them."""
        for run in self.runs:
            run.lazy.close()

    # ------------------------------------------------------------------ reporting
    def summary(self, run: MethodRun | None = None, *, fresh: bool = False,
                stream: StreamFigures | None = None) -> MethodReport:
        """A method's counters and errors so far (the first method's by default);
        ``fresh``: score the held-out samples now; ``stream``: the stream's figures (the
        node's) to include."""
        run = run or self.first
        core = run.core
        previous = tuple(run.previous)
        if core is None:
            early = run.lazy.early
            return MethodReport(method=run.method, processed=early.processed,
                                skipped=SkipCounts.of(early.skipped), stream=stream,
                                previous=previous)
        counts = core.counts
        stats = core.error_stats()
        validation = run.validation(fresh=fresh)
        detector = run.detector
        per_joint = MethodReport.per_joint
        return MethodReport(
            method=run.method, trainer=self.settings.trainer,
            joint_names=tuple(self.names),
            processed=counts.processed, predicted=counts.predicted, learnt=counts.learnt,
            held_out=counts.held_out, refused=counts.refused, clipped=counts.clipped,
            no_effort=counts.no_effort, pending=counts.pending,
            skipped=SkipCounts.of(counts.skipped),
            mse=per_joint(stats.mse), nmse=per_joint(stats.nmse),
            mse_total=float(stats.mse_total), nmse_total=float(stats.nmse_total),
            validation_nmse=None if validation is None else per_joint(validation.nmse),
            validation_nmse_total=(None if validation is None
                                   else float(validation.nmse_total)),
            contacts=run.contacts,
            contact_armed=detector is not None and detector.armed,
            contact_thresholds=(None if detector is None
                                else per_joint(detector.thresholds)),
            contact_held=detector.held if detector is not None else 0,
            contact_delay_p50_ms=run.decisions.percentile_ms(50),
            contact_delay_p99_ms=run.decisions.percentile_ms(99),
            worst_lag_ms=run.worst_lag_ns / 1e6, lag_p50_ms=run.lags.percentile_ms(50),
            lag_p99_ms=run.lags.percentile_ms(99),
            stream=stream, learning=run.learning(), previous=previous)

    def health_figures(self, run: MethodRun) -> HealthFigures:
        """A method's figures for ``nodes.health.identifier_health`` (the stream's apart);
        the lag is the largest since the last call."""
        counts = run.lazy.counts
        error_finite, validation = True, None
        core = run.core
        if core is not None:
            if core.errors.count:
                error_finite = bool(np.isfinite(core.error_stats().mse_total))
            stats = run.validation()
            validation = float(stats.nmse_total) if stats is not None else None
        lag_ns, run.period_lag_ns = run.period_lag_ns, 0
        background = run.background
        return HealthFigures(
            processed=counts.processed, learnt=counts.learnt,
            skipped=SkipCounts.of(counts.skipped),
            period_worst_lag_ms=lag_ns / 1e6 if lag_ns else None,
            error_finite=error_finite, validation_nmse_total=validation,
            learning=self.settings.learn,
            update_rate=background.rate() if background is not None else None,
            update_overdue_s=background.overdue() if background is not None else None,
            contact=run.contact_health(),
            contact_arm_nmse=self.settings.contact_arm_nmse)

    def save(self, run: MethodRun | None = None) -> tuple[bool, str]:
        """Save a method's model (the first's by default) to its ``save_path`` now
        (atomically: a failed save leaves the previous file intact); return success and
        what happened."""
        run = run or self.first
        path = self.paths['save_path'][run.method]
        if not path:
            return False, 'no save_path: start the node with -p save_path:=<file>.npz'
        if run.network is None or run.core is None:
            return False, 'no model yet: no valid sample has fixed the joints'
        try:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            run.network.save(path)
        except OSError as exc:
            return False, f'saving to {path} failed: {exc}'
        return True, f'saved to {path} after {run.core.counts.learnt} learnt samples'
