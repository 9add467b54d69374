"""Contact detection measured offline: an identified model against a raw-effort threshold.

The identifier's pipeline, without ROS: the SCARA tracks ``scara_sim``'s default excitation
(``sequence``) with the simulator's sensor noise; an FFS network learns ``train_s`` seconds of
it online as the node does (input stage with the zero-phase q'', the synchronous
Levenberg-Marquardt reservoir trainer, 10 % held-out blocks); it is then frozen, and a
:class:`~scara_ident_ros.identification.contact_detector.ContactDetector` takes its thresholds
from the held-out residuals. On motions the model never learnt (other seeds):

- a clean run (no contact) gives the false alarms: rising edges of "some joint in contact";
- a run with external effort pulses (``amplitude`` of a random joint's effort limit, random
  sign, ``pulse_s`` long, one every ``spacing_s`` on average) gives the detection rate and
  the delay from a pulse's start to the first sample flagged on its joint, within the pulse
  or ``tail_s`` after it. The delay is that of the sample's stamp; the node publishes it
  ``lag`` samples later (the zero-phase q'').

The baseline flags a joint when its raw measured ``|effort|`` exceeds a fixed threshold
``c · max|effort_j|`` of the clean run, ``c`` the smallest that gives no more false alarms on
the clean run than the model's detector: the same false-alarm rate, compared on detection.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import numpy as np
import numpy.typing as npt

from scara_ident_ros.dynamics import ScaraParams
from scara_ident_ros.dynamics.joint_limits import LIMIT_NAMES, JointLimits
from scara_ident_ros.estimator import Estimator
from scara_ident_ros.identification import InputStage, JointMap, OnlineIdentifier
from scara_ident_ros.identification.contact_detector import ContactDetector
from scara_ident_ros.identification.identifier_settings import IdentifierSettings
from scara_ident_ros.identification.identifier_builder import build_identifier
from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.dynamics.joint_limits import load_motion_limits
from scara_ident_ros.excitation import LoopSettings
from scara_ident_ros.excitation.simulated_loop import simulate_loop
from scara_ident_ros.resources import share_dir
from scara_ident_ros.sim import SimConfig, SimRecord, Simulator, make_trajectory

__all__ = ['ContactRun', 'Pulse', 'Trained', 'alarm_events', 'baseline_flags', 'detect',
           'evaluate', 'loop_record', 'matched_baseline', 'pulse_record', 'residuals_of',
           'train_model']

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class Pulse:
    """One external effort pulse: from sample ``start`` for ``length`` samples, ``effort``
    (N·m or N) on ``joint``."""

    start: int
    length: int
    joint: int
    effort: float


@dataclass(frozen=True)
class ContactRun:
    """What one detector found (module docstring): ``detected`` of ``pulses``, their
    ``delays_s`` (detected,) in s, and ``false_alarms`` in ``clean_s`` seconds."""

    detected: int
    pulses: int
    delays_s: FloatArray
    false_alarms: int
    clean_s: float

    @property
    def rate(self) -> float:
        """Share of the pulses detected."""
        return self.detected / self.pulses if self.pulses else float('nan')

    @property
    def false_alarms_per_10_min(self) -> float:
        """False alarms per 600 s of clean run."""
        return self.false_alarms * 600.0 / self.clean_s


@dataclass(frozen=True)
class Trained:
    """A network learnt online and frozen, with what contact calibration takes from it.

    Attributes
    ----------
    net : FeedForwardNet
    residuals : ndarray of shape (K, L, 4)
        Its measured − predicted effort (N·m or N) on the held-out segments.
    inputs : ndarray of shape (K, L, 12)
        The segments' inputs [q, q', q''].
    blocks : ndarray of shape (K,)
        The held-out block of each segment.
    nmse : float
        Its validation NMSE (mean over the joints).
    lag : int
        Samples by which its predictions follow their samples.
    prior : ndarray of shape (N, 4)
        The a-priori residual of every sample of the stream so far, measured − predicted
        before it was learnt (N·m or N): what the node's contact check sees.
    prior_inputs : ndarray of shape (N, 12)
        Their inputs [q, q', q''].
    """

    net: FeedForwardNet
    residuals: FloatArray
    inputs: FloatArray
    blocks: npt.NDArray[np.int64]
    nmse: float
    lag: int
    prior: FloatArray
    prior_inputs: FloatArray


def loop_record(params: ScaraParams, *, seconds: float, seed: int, config: SimConfig,
                external: FloatArray | None = None) -> SimRecord:
    """The excitation loop's stream (``excitation`` -> ``scara_sim trajectory:=external``,
    its defaults, seed ``seed``), with external efforts (samples, 4) if given."""
    limits = load_motion_limits(urdf_file=str(share_dir() / 'urdf' / 'scara.urdf'),
                                joint_names=params.joint_names)
    return simulate_loop(params, limits, seconds=seconds, settings=LoopSettings(seed=seed),
                         config=config, external=external).record


def train_model(params: ScaraParams, *, seconds: float, seed: int, config: SimConfig,
                hidden: int = 40, stream: str = 'sequence', every_s: float = 0.0,
                on_every: Callable[[float, Trained], None] | None = None) -> Trained:
    """An FFS network trained online on ``seconds`` of ``stream`` (``sequence``: scara_sim's
    own; ``loop``: the excitation loop's) as the node does, then frozen.

    ``on_every(t, trained)``: called after every ``every_s`` s of stream (t in s) with the
    model as it is then (not a copy: read it at once), as the node's contact calibration
    sees it; not before the held-out samples can be scored.
    """
    n = round(seconds / config.dt)
    record = (loop_record(params, seconds=seconds, seed=seed, config=config)
              if stream == 'loop' else
              Simulator(params, make_trajectory('sequence', params, seed), config).simulate(n))
    limits = JointLimits.of(params.joint_names,
                            {name: params.array(name) for name in LIMIT_NAMES}, source='robot')
    ident = build_identifier(params.joint_names, IdentifierSettings.defaults(
        method='ffs', trainer='lm', hidden_units=hidden, seed=seed), limits)
    net = cast(FeedForwardNet, ident.model)
    names = params.joint_names
    stage = InputStage(JointMap(names, n_joints=4))
    stamps, inputs, _ = stage.batch(record.stamp_ns, names, record.q, record.qd,
                                    record.effort)
    prior = np.empty((len(stamps), 4))
    count = 0
    every = round(every_s / config.dt) if on_every is not None and every_s > 0 else 0
    for i in range(len(record)):
        for result in ident.process(int(record.stamp_ns[i]), names, record.q[i],
                                    record.qd[i], record.effort[i]):
            if result.effort is not None and result.measured is not None:
                assert result.stamp_ns == stamps[count]  # the same stage, the same samples
                prior[count] = result.measured - result.effort
                count += 1
        if every and (i + 1) % every == 0 and on_every is not None:
            now = _frozen(ident, net, prior[:count], inputs[:count])
            if now is not None:
                on_every((i + 1) * config.dt, now)
    trained = _frozen(ident, net, prior[:count], inputs[:count])
    if trained is None:
        raise ValueError(f'{seconds} s of stream held out too few samples to score')
    return trained


def _frozen(ident: OnlineIdentifier, net: FeedForwardNet, prior: FloatArray,
            prior_inputs: FloatArray) -> Trained | None:
    """The model as it is, with its residuals on the held-out segments and the stream's
    a-priori residuals so far (copied); None before the held-out ones can be scored."""
    stats = ident.validation_stats()
    segments = ident.holdout.segments if ident.holdout is not None else None
    if stats is None or segments is None or len(segments) == 0:
        return None
    X = segments.X.copy()
    residuals = segments.Y - net.predict(X.reshape(-1, 12)).reshape(segments.Y.shape)
    return Trained(net, residuals, X, segments.blocks.copy(), float(stats.nmse_total),
                   ident.lag, prior.copy(), prior_inputs.copy())


def pulse_record(params: ScaraParams, *, seconds: float, seed: int, config: SimConfig,
                 amplitude: float = 0.1, pulse_s: float = 0.1, spacing_s: float = 0.0,
                 stream: str = 'sequence') -> tuple[SimRecord, list[Pulse]]:
    """Simulate ``seconds`` of unseen ``stream`` motion (as :func:`train_model`) with
    external effort pulses.

    Pulses of ``amplitude`` times a joint's effort limit (the joints in turn, random sign),
    ``pulse_s`` long, start at random times at least ``spacing_s`` apart (their average
    spacing is ``spacing_s`` · 1.5); ``spacing_s`` 0: no pulses (a clean run).
    """
    n = round(seconds / config.dt)
    length = max(1, round(pulse_s / config.dt))
    pulses: list[Pulse] = []
    if spacing_s > 0:
        rng = np.random.default_rng([seed, 7])
        gap = round(spacing_s / config.dt)
        start = gap // 2
        limits = params.array('effort_max')
        while start + length + gap // 2 < n:
            joint = len(pulses) % 4
            effort = float(amplitude * limits[joint] * rng.choice((-1.0, 1.0)))
            pulses.append(Pulse(start, length, joint, effort))
            start += length + gap + int(rng.integers(gap))
    external = np.zeros((n, 4))
    for pulse in pulses:
        external[pulse.start:pulse.start + pulse.length, pulse.joint] = pulse.effort
    if stream == 'loop':
        return loop_record(params, seconds=seconds, seed=seed, config=config,
                           external=external), pulses
    sim = Simulator(params, make_trajectory('sequence', params, seed), config)
    rows = []
    current = None
    for k in range(n):
        row = external[k]
        if current is None or not np.array_equal(row, current):
            sim.apply_external(row)
            current = row
        rows.append(sim.advance())
    stamps = np.array([row[0] for row in rows], dtype=np.int64)
    columns = [np.array([row[i] for row in rows], dtype=float).reshape(n, 4)
               for i in range(1, 5)]
    return SimRecord(stamps, *columns), pulses


def residuals_of(net: Estimator, record: SimRecord, names: tuple[str, ...]
                 ) -> tuple[npt.NDArray[np.int64], FloatArray, FloatArray]:
    """The frozen model's τ_ext = measured − predicted on a record, through the input stage.

    Returns the record's index of each predicted sample (K,), τ_ext (K, 4) and the measured
    effort (K, 4).
    """
    stage = InputStage(JointMap(names, n_joints=4))
    stamps, X, Y = stage.batch(record.stamp_ns, names, record.q, record.qd, record.effort)
    index = np.searchsorted(record.stamp_ns, stamps)
    return index, Y - net.predict(X), Y


def detect(detector: ContactDetector, external: FloatArray,
           inputs: FloatArray | None = None) -> BoolArray:
    """The detector's flags (K, n) sample by sample over τ_ext (K, n), with the samples'
    inputs (K, 3n) for the envelope if given."""
    if inputs is None:
        return np.array([detector.check(row) for row in external])
    return np.array([detector.check(row, x) for row, x in zip(external, inputs)])


def baseline_flags(effort: FloatArray, thresholds: FloatArray) -> BoolArray:
    """A fixed threshold on the raw measured effort: |effort| (K, n) > thresholds (n,)."""
    return np.abs(effort) > thresholds


def alarm_events(flags: BoolArray) -> int:
    """Rising edges of "some joint flagged" over flags (K, n)."""
    some = np.any(flags, axis=1).astype(np.int8)
    return int(some[0] + np.count_nonzero(np.diff(some) == 1)) if some.size else 0


def evaluate(clean_flags: BoolArray, pulse_flags: BoolArray, pulse_index: npt.NDArray[np.int64],
             pulses: list[Pulse], *, dt: float, clean_s: float, tail_s: float = 0.05
             ) -> ContactRun:
    """Detection rate and delays on the pulse run, false alarms on the clean run.

    ``pulse_index`` is the record index of each row of ``pulse_flags``.
    """
    delays = []
    tail = round(tail_s / dt)
    for pulse in pulses:
        rows = np.flatnonzero((pulse_index >= pulse.start)
                              & (pulse_index < pulse.start + pulse.length + tail))
        hits = rows[pulse_flags[rows, pulse.joint]]
        if hits.size:
            delays.append((pulse_index[hits[0]] - pulse.start) * dt)
    return ContactRun(len(delays), len(pulses), np.array(delays), alarm_events(clean_flags),
                      clean_s)


def matched_baseline(clean_effort: FloatArray, allowed: int,
                     check: Callable[[FloatArray], BoolArray] | None = None) -> FloatArray:
    """Per-joint raw-effort thresholds ``c · max|effort_j|`` of the clean run, with the
    smallest ``c`` (bisection) that gives at most ``allowed`` false alarms on it."""
    peak = np.max(np.abs(clean_effort), axis=0)
    lo, hi = 0.0, 1.0 + 1e-9  # at hi nothing on the clean run is over
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if alarm_events(baseline_flags(clean_effort, mid * peak)) <= allowed:
            hi = mid
        else:
            lo = mid
    return np.asarray(hi * peak)
