"""Contact detection from an identified model, armed only at a bounded false-alarm rate.

A model of the free robot's inverse dynamics predicts the effort the joints need for the
motion measured; an external effort (a contact, a collision) shows as the part of the
measured effort it does not explain, the *external torque* ``τ_ext = measured − predicted``.
That residual is also the model's error, so the thresholds come from the model's residuals
on free motion it had not learnt when it predicted it, kept in the order of the stream so
that they keep their course in time:

- ``calibrate_on='a-priori'`` (default): the *a-priori* (prequential) residuals, every
  sample's τ_ext as :meth:`ContactDetector.check` saw it, predicted before the sample was
  learnt, over the last ``recent_s`` seconds of stream (at most ``recent_s`` thousand
  samples are kept; a sample flagged as a contact is not kept). That is what the check meets:
  motion the model has not learnt yet, predicted by a model that goes on learning.
- ``calibrate_on='held-out'``: the current model's residuals on the held-out segments of
  :class:`~scara_ident_ros.identification.holdout.Holdout`. A held-out block lies between
  learnt motion and is scored by a model that learnt what came before and after it:
  interpolation. On new motion the model errs more, and thresholds from held-out blocks
  gave 4, 2 and 0 false alarms in 10 minutes where the bound allows 1 per hour
  (``benchmarks/contact.md``).

**Thresholds from the tail, not the spread.** A joint is in contact when ``|τ_ext_j − c_j|``
(``c_j`` the residuals' median) exceeds ``T_j`` for ``min_samples`` consecutive samples. What
matters for false alarms is how often the free-motion residual does that, a far tail of its
distribution that a spread (MAD) does not describe: model errors are heavy-tailed (a
friction step, a turn of the motion). Residuals are autocorrelated, so single samples are
not independent draws. The draws are maxima ``M_kj`` of ``|τ_ext_j − c_j|`` (of its running
minimum over ``min_samples``, the statistic an alarm needs) over units of samples long
against joint j's correlation time τ_j (the first lag where its residual's autocorrelation
falls below 0.1, measured within the segments). A-priori residuals: joint j's maxima over
consecutive runs of ``max(2τ_j, 100)`` samples of the window, τ_j measured within runs of
1000 samples (at most 1000), each run a draw. Held-out segments: a segment of L samples when
``2τ_j <= L``, counted as ``K · min(1, L / (2τ_j))`` independent ones; else (the model's
error outlasts a segment, as on a noise-free stream) all the kept segments of one held-out
block together, one draw per block. Each joint has its own draws: a joint whose residual
is noise-like (a friction joint) gets a draw per segment while a smooth one waits for
blocks.

The exceedance probability a bound of ``λ`` false alarms per hour allows per draw of joint
j is ``p_j = λ · D_j / 3600 / n``, D_j the mean duration of its draws' samples (the union
over the n joints stays within ``λ``), far beyond what the draws show directly (1 per hour,
0.5 s blocks: p ≈ 3.5e-5 with 4 joints). So the tail is extrapolated (peaks over a
threshold): above ``u_j``, the (k+1)-th largest draw (the smallest of few draws), the
excesses are taken as exponential with their mean ``s_j``; the margin for the
calibration's size is the *predictive* exceedance probability
``(k/K) · (1 + t / (k' s_j))^(−k')`` (the exponential tail with its scale estimated from
``k' = k · K_eff / K`` independent excesses, under a scale-invariant prior: heavier than the
fitted tail, the fewer excesses the heavier: a safety factor that shrinks as draws
accumulate), solved for ``t``; if the excesses look heavier than exponential
(method-of-moments generalised-Pareto shape ξ > 0), the generalised-Pareto quantile is
taken when it is larger. ``T_j = max(u_j + t_j, sigma · 1.4826 · MAD_j)``.

**The bound.** If the draws are independent and their distribution above ``u_j`` has a
tail no heavier than exponential (an increasing hazard rate, as the maxima of Gaussian-like
errors have; the mean excess above a low ``u_j`` then overstates the far tail's scale), the
posterior-predictive probability that a new draw of joint j exceeds ``T_j`` is at most
``p_j``, so the expected false-alarm rate on free motion like the calibration's is at most
``λ`` per hour, whatever the number of draws: few draws give higher thresholds, not a
weaker bound. A heavier tail is caught only as far as the moment estimate of ξ sees it.
Nor does it cover a shift of the residual's distribution between the calibration and the
motion checked: the reason the a-priori residuals, the motion the check meets, are the
default (held-out blocks understate the error on new motion).

**Armed** only when all hold: the validation NMSE is below ``arm_nmse`` (the model
identifies); at least :data:`MIN_DRAWS` independent draws on every joint (the predictive
margin covers the scale's uncertainty; below that the tail's shape is a guess: a-priori,
a few seconds of stream; held out, on a noise-free stream 8 held-out blocks, about 40 s at
the default 10 % held out); the
false-alarm rate the tail model gives at the thresholds (with the margin) is at most
``false_alarms_per_hour``; and no calibration draw is over its thresholds. An unarmed
detector never flags.

**Envelope.** The thresholds hold for the motion they were calibrated on: q and q' (and q''
with ``envelope_acceleration``) within the range per input of the calibration's samples
(a-priori: the window's and the held-out segments'), widened by
``envelope_margin`` of that range. A sample outside it is not checked (no flag; counted in
``held``, the diagnostics say so): the model's error there is not what the thresholds
measured. q'' is left out by default because a contact is itself an acceleration the free
motion does not have: holding on q'' holds the very samples a collision makes (on the
excitation loop it delayed the detection of 10 % pulses from 10 to 37 ms,
``benchmarks/contact.md``). The default margin is half the range: unseen motion of the kind
calibrated on leaves the window's range by more than a quarter of it, and a margin of a
quarter held whole pulses there (``benchmarks/contact.md``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

__all__ = ['A_PRIORI', 'ARM_NMSE', 'Calibration', 'ContactDetector', 'ENVELOPE_MARGIN',
           'FALSE_ALARMS_PER_HOUR', 'HELD_OUT', 'MAD_TO_SIGMA', 'MIN_DRAWS', 'MIN_SAMPLES',
           'RECENT_CHUNK', 'RECENT_DRAW', 'RECENT_S', 'SIGMA', 'Tail', 'correlation_time',
           'robust_spread']

MAD_TO_SIGMA = 1.4826  # a Gaussian's standard deviation over its median absolute deviation
#: Defaults of the node's parameters contact_<name in lower case>
SIGMA = 5.0  # robust standard deviations: the lowest threshold
ARM_NMSE = 0.01  # validation NMSE below which detection may be armed
MIN_SAMPLES = 1  # consecutive samples over a threshold before a contact
FALSE_ALARMS_PER_HOUR = 1.0  # the false-alarm rate the thresholds are set to meet
ENVELOPE_MARGIN = 0.5  # fraction of the calibrated range the envelope is widened by
MIN_DRAWS = 8  # independent draws (segments or blocks) per joint before detection is armed
ACF_LEVEL = 0.1  # autocorrelation below which residuals count as decorrelated
A_PRIORI, HELD_OUT = 'a-priori', 'held-out'  # what the thresholds are calibrated on
RECENT_S = 25.0  # s of the latest a-priori residuals the thresholds are calibrated on
RECENT_RATE_HZ = 1000.0  # the highest stream rate whose whole RECENT_S is kept
RECENT_CHUNK = 1000  # samples per run the a-priori residuals' correlation time is taken on
RECENT_DRAW = 100  # samples of the shortest a-priori draw
SECONDS_PER_HOUR = 3600.0


def robust_spread(residuals: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-joint robust standard deviation of residuals (K, n): 1.4826 · MAD, shape (n,).

    Rows with a non-finite value are left out; a joint without any finite residual is NaN.
    """
    r = np.asarray(residuals, dtype=float)
    if r.ndim != 2:
        raise ValueError(f'residuals must have shape (K, n), got {r.shape}')
    r = np.ascontiguousarray(r[np.all(np.isfinite(r), axis=1)].T)  # joints in rows: faster
    if r.shape[1] == 0:
        return np.full(r.shape[0], np.nan)
    deviation = np.abs(r - np.median(r, axis=1, keepdims=True))
    return np.asarray(MAD_TO_SIGMA * np.median(deviation, axis=1))


def correlation_time(segments: NDArray[np.float64]) -> NDArray[np.int64]:
    """Per joint, the first lag (samples) where the residuals' autocorrelation within the
    segments (K, L, n) falls below 0.1; ``L`` if it never does; 1 for L = 1.

    The autocovariance of every lag at once, by FFT along the segments (zero-padded to 2L:
    no wrap-around), about the mean over all segments.
    """
    k, length, n = segments.shape
    if length < 2:
        return np.ones(n, dtype=np.int64)
    centred = segments - segments.mean(axis=(0, 1))
    spectrum = np.fft.rfft(centred, n=2 * length, axis=1)
    power = (spectrum * spectrum.conj()).real.sum(axis=0)  # (L + 1, n)
    acov = np.fft.irfft(power, n=2 * length, axis=0)[:length]  # (L, n), lag 0..L-1
    acov /= (k * (length - np.arange(length)))[:, None]  # the pairs at each lag
    result = np.full(n, length, dtype=np.int64)
    for j in range(n):
        if acov[0, j] <= 0:
            result[j] = 1
            continue
        below = np.flatnonzero(acov[1:, j] / acov[0, j] < ACF_LEVEL)
        if below.size:
            result[j] = below[0] + 1
    return result


class Tail(NamedTuple):
    """One joint's fitted tail of segment maxima (module docstring).

    ``n_segments`` segments, ``k`` excesses over ``u``, their mean ``scale``, the
    generalised-Pareto shape ξ and scale by moments (ξ 0: lighter than exponential), and
    ``independent`` segments among the count.
    """

    n_segments: int
    k: int
    u: float
    scale: float
    shape: float
    gpd_scale: float
    independent: float

    @classmethod
    def fit(cls, maxima: NDArray[np.float64], independent: float) -> Tail:
        """Fit the tail of one joint's draws (K,), K >= 2: the k = K // 5 largest (at
        least 10, at most 100 and K − 1) over the next one."""
        m = np.sort(np.asarray(maxima, dtype=float))
        count = m.size
        k = int(min(max(count // 5, 10), 100, count - 1))
        u = float(m[count - k - 1])
        excess = m[count - k:] - u
        scale = max(float(excess.mean()), 1e-300)
        var = float(excess.var(ddof=1)) if k > 1 else 0.0
        shape = max(0.5 * (1.0 - scale * scale / var), 0.0) if var > 0 else 0.0
        gpd_scale = 0.5 * scale * (scale * scale / var + 1.0) if shape > 0 else scale
        return cls(count, k, u, scale, shape, gpd_scale, min(independent, count))

    @property
    def k_eff(self) -> float:
        """Independent excesses: k scaled by the share of independent segments."""
        return max(self.k * self.independent / self.n_segments, 1.0)

    def level(self, p: float) -> float:
        """The level a segment maximum exceeds with probability ``p`` in (0, 1), the
        calibration's size counted (module docstring)."""
        ratio = (self.k / self.n_segments) / p
        if ratio <= 1.0:  # within the sample: the tail's start is already rarer
            return self.u
        k_eff = self.k_eff
        t = k_eff * self.scale * (ratio ** (1.0 / k_eff) - 1.0)
        if self.shape > 0:
            t = max(t, self.gpd_scale / self.shape * (ratio ** self.shape - 1.0))
        return self.u + t

    def exceedance(self, level: float) -> float:
        """Probability per segment that the maximum exceeds ``level``: the larger of the
        predictive exponential and the generalised-Pareto tails."""
        t = max(level - self.u, 0.0)
        k_eff = self.k_eff
        prob = (1.0 + t / (k_eff * self.scale)) ** (-k_eff)
        if self.shape > 0:
            prob = max(prob, (1.0 + self.shape * t / self.gpd_scale) ** (-1.0 / self.shape))
        return self.k / self.n_segments * prob


class _Draws:
    """Each joint's independent draws (module docstring) and what else a calibration takes
    from its residuals: their ``centre`` and robust ``spread`` (n,), correlation times
    ``tau`` (n,) (samples), the ``inputs`` (M, 3n) they were predicted from (None: not
    known), and ``segments``, the units counted."""

    def __init__(self, values: list[NDArray[np.float64]], durations: list[float],
                 independent: NDArray[np.float64], segments: int, tau: NDArray[np.int64],
                 centre: NDArray[np.float64], spread: NDArray[np.float64],
                 inputs: NDArray[np.float64] | None) -> None:
        self.values, self.durations, self.independent = values, durations, independent
        self.segments, self.tau, self.centre, self.spread = segments, tau, centre, spread
        self.inputs = inputs

    @classmethod
    def of_segments(cls, maxima: NDArray[np.float64], tau: NDArray[np.int64], length: int,
                    blocks: NDArray[np.int64] | None, centre: NDArray[np.float64],
                    spread: NDArray[np.float64], inputs: NDArray[np.float64] | None
                    ) -> _Draws:
        """Held-out segments' maxima (K, n) of ``length`` samples and their ``blocks``
        (K,): the segments for a joint with ``2τ_j <= L`` (all joints without blocks),
        else the maximum over each block's segments."""
        count = len(maxima)
        by_segment = (2 * tau <= length) | (blocks is None)
        independent = count * np.minimum(1.0, length / (2.0 * tau))
        grouped = maxima  # (B, n): one row a block
        if not by_segment.all() and blocks is not None:
            _, group = np.unique(blocks, return_inverse=True)
            grouped = np.zeros((int(group.max()) + 1, maxima.shape[1]))
            np.maximum.at(grouped, group, maxima)
            independent[~by_segment] = len(grouped)
        values = [maxima[:, j] if by_segment[j] else grouped[:, j]
                  for j in range(maxima.shape[1])]
        durations = [float(length) if by_segment[j] else length * count / len(grouped)
                     for j in range(maxima.shape[1])]
        return cls(values, durations, independent, count, tau, centre, spread, inputs)

    @classmethod
    def of_runs(cls, deviation: NDArray[np.float64], runs: NDArray[np.int64],
                tau: NDArray[np.int64], centre: NDArray[np.float64],
                spread: NDArray[np.float64], inputs: NDArray[np.float64] | None
                ) -> _Draws:
        """A contiguous stretch's |τ_ext − centre| (N, n): joint j's maxima over its
        consecutive runs of ``runs[j]`` samples (the latest ones; a partial oldest run
        left out), each an independent draw."""
        count, n = deviation.shape
        values, durations = [], []
        for j in range(n):
            k = count // int(runs[j])
            values.append(deviation[count - k * int(runs[j]):, j].reshape(k, -1).max(axis=1))
            durations.append(float(runs[j]))
        independent = np.array([float(len(v)) for v in values])
        return cls(values, durations, independent, count // RECENT_DRAW, tau, centre,
                   spread, inputs)

    @property
    def fewest(self) -> float:
        """Independent draws, the fewest over the joints."""
        return float(self.independent.min())

    def of(self, joint: int) -> tuple[NDArray[np.float64], float, float]:
        """Joint ``joint``'s draws, the mean samples a draw spans, the independent ones."""
        return self.values[joint], self.durations[joint], float(self.independent[joint])


class _Recent:
    """The last ``capacity`` a-priori residuals (n,) and inputs (3n,) checked, a ring."""

    def __init__(self, capacity: int, n: int) -> None:
        self.residuals = np.full((capacity, n), np.nan)
        self.inputs = np.full((capacity, 3 * n), np.nan)
        self.written = 0
        self.has_inputs = True  # every sample came with its input

    def add(self, residual: NDArray[np.float64], x: NDArray[np.float64] | None) -> None:
        """Keep one sample's residual (n,) and input (3n,) or None."""
        i = self.written % len(self.residuals)
        self.residuals[i] = residual
        if x is None:
            self.has_inputs = False
        else:
            self.inputs[i] = x
        self.written += 1

    def window(self, last: int) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """The ``last`` kept residuals (N, n) and inputs (N, 3n) (None unless every
        sample had one), N at most ``last``, oldest first (copies)."""
        capacity = len(self.residuals)
        count = min(last, capacity, self.written)
        start, end = (self.written - count) % capacity, self.written % capacity

        def latest(a: NDArray[np.float64]) -> NDArray[np.float64]:
            if count == 0:
                return a[:0].copy()
            if start < end or end == 0:
                return a[start:end or capacity].copy()
            return np.concatenate([a[start:], a[:end]])

        return latest(self.residuals), latest(self.inputs) if self.has_inputs else None

    def clear(self) -> None:
        """Forget every sample."""
        self.written = 0
        self.has_inputs = True

    def copy(self) -> _Recent:
        """An independent copy."""
        other = _Recent(1, self.residuals.shape[1])
        other.residuals, other.inputs = self.residuals.copy(), self.inputs.copy()
        other.written, other.has_inputs = self.written, self.has_inputs
        return other


@dataclass(frozen=True)
class Calibration:
    """What one calibration found (all per joint arrays of shape (n,)).

    Attributes
    ----------
    segments : int
        Calibration segments K (held-out runs of ``length`` samples).
    independent : float
        Independent draws counted, the fewest over the joints: ``K · min(1, L / (2τ_j))``
        segments, or the blocks.
    correlation_samples : ndarray of int
        The residuals' correlation time τ (samples).
    centre, thresholds : ndarray or None
        Median of the residuals and |τ_ext − centre| over which a joint is in contact
        (N·m or N); None without enough residuals.
    false_alarms_per_hour : float or None
        The rate the tail model gives at the thresholds, the calibration's size counted.
    over : int
        Calibration draws over their joint's threshold.
    why_not : str
        '' when armed, else why not.
    """

    segments: int = 0
    independent: float = 0.0
    correlation_samples: NDArray[np.int64] | None = None
    centre: NDArray[np.float64] | None = None
    thresholds: NDArray[np.float64] | None = None
    false_alarms_per_hour: float | None = None
    over: int = 0
    why_not: str = 'not calibrated yet'
    lo: NDArray[np.float64] | None = field(default=None, repr=False)
    hi: NDArray[np.float64] | None = field(default=None, repr=False)


class ContactDetector:
    """Per-joint thresholds from a-priori or held-out residuals, the arming rule, the check.

    ``sigma``, ``arm_nmse``, ``min_samples``, ``false_alarms_per_hour``,
    ``envelope_margin``, ``envelope_acceleration``, ``calibrate_on`` and ``recent_s`` (s) are
    as in the module docstring.

    Attributes
    ----------
    calibration : Calibration
        The latest :meth:`calibrate`'s outcome.
    validation_nmse : float or None
        The validation NMSE of the latest :meth:`calibrate`.
    held : int
        Samples not checked since the last :meth:`reset` because their input left the
        calibrated envelope.
    """

    def __init__(self, n_joints: int, *, sigma: float = SIGMA, arm_nmse: float = ARM_NMSE,
                 min_samples: int = MIN_SAMPLES,
                 false_alarms_per_hour: float = FALSE_ALARMS_PER_HOUR,
                 envelope_margin: float = ENVELOPE_MARGIN, envelope_acceleration: bool = False,
                 calibrate_on: str = A_PRIORI, recent_s: float = RECENT_S) -> None:
        if n_joints < 1:
            raise ValueError(f'n_joints must be at least 1, got {n_joints}')
        if not (math.isfinite(sigma) and sigma > 0):
            raise ValueError(f'contact sigma must be > 0, got {sigma}')
        if not (math.isfinite(arm_nmse) and arm_nmse > 0):
            raise ValueError(f'contact arm NMSE must be > 0, got {arm_nmse}')
        if min_samples < 1:
            raise ValueError(f'contact min_samples must be at least 1, got {min_samples}')
        if not (math.isfinite(false_alarms_per_hour) and false_alarms_per_hour > 0):
            raise ValueError('contact false alarms per hour must be > 0, got '
                             f'{false_alarms_per_hour}')
        if not (math.isfinite(envelope_margin) and envelope_margin >= 0):
            raise ValueError(f'contact envelope margin must be >= 0, got {envelope_margin}')
        if calibrate_on not in (A_PRIORI, HELD_OUT):
            raise ValueError(f'contact calibration on {calibrate_on!r}: choose {A_PRIORI!r} '
                             f'or {HELD_OUT!r}')
        if not (math.isfinite(recent_s) and recent_s > 0):
            raise ValueError(f'contact recent seconds must be > 0, got {recent_s}')
        self.n_joints = n_joints
        self.sigma = float(sigma)
        self.arm_nmse = float(arm_nmse)
        self.min_samples = int(min_samples)
        self.false_alarms_per_hour = float(false_alarms_per_hour)
        self.envelope_margin = float(envelope_margin)
        self.envelope_acceleration = bool(envelope_acceleration)
        self.calibrate_on = calibrate_on
        self.recent_s = float(recent_s)
        self._recent = _Recent(max(round(recent_s * RECENT_RATE_HZ), 1), n_joints)
        self.calibration = Calibration()
        self.validation_nmse: float | None = None
        self.held = 0
        self._over = np.zeros(n_joints, dtype=np.int64)  # consecutive samples over, per joint
        self._active: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self._envelope: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    @property
    def thresholds(self) -> NDArray[np.float64] | None:
        """|τ_ext − centre| per joint (N·m or N) over which a joint is in contact; None
        until calibrated."""
        return self.calibration.thresholds

    @property
    def armed(self) -> bool:
        """Whether detection is on (module docstring: the arming rule)."""
        return self._active is not None

    def calibrate(self, residuals: NDArray[np.float64] | None,
                  validation_nmse: float | None, *,
                  inputs: NDArray[np.float64] | None = None,
                  sample_period_s: float = 1e-3,
                  blocks: NDArray[np.int64] | None = None) -> Calibration:
        """Take the current model's held-out residuals and validation NMSE, and (a-priori)
        the residuals :meth:`check` and :meth:`observe` kept; arm or disarm.

        Parameters
        ----------
        residuals : ndarray of shape (K, L, n) or (K, n), or None
            Measured − predicted effort (N·m or N) on K held-out segments of L contiguous
            samples; (K, n): K independent single samples. Not used a-priori (their
            inputs are).
        validation_nmse : float or None
            The model's validation NMSE (mean over the joints).
        inputs : ndarray of shape (K, L, 3n) or (K, 3n), optional
            The segments' inputs [q, q', q''] (rad or m, /s, /s²): the envelope; without
            them every sample is checked.
        sample_period_s : float
            The stream's sample period (s): a segment lasts ``L · sample_period_s``.
        blocks : ndarray of shape (K,), optional
            The held-out block of each segment; without them each segment is its own.
        """
        nmse = None if validation_nmse is None or not math.isfinite(validation_nmse) \
            else float(validation_nmse)
        self.validation_nmse = nmse
        self.calibration = self._calibrate(residuals, nmse, inputs, sample_period_s, blocks)
        c = self.calibration
        self._active = ((c.centre, c.thresholds) if not c.why_not and c.centre is not None
                        and c.thresholds is not None else None)
        self._envelope = (c.lo, c.hi) if c.lo is not None and c.hi is not None else None
        return c

    def _calibrate(self, residuals: NDArray[np.float64] | None, nmse: float | None,
                   inputs: NDArray[np.float64] | None, period: float,
                   blocks: NDArray[np.int64] | None) -> Calibration:
        drawn = (self._recent_draws(max(round(self.recent_s / period), 1))
                 if self.calibrate_on == A_PRIORI
                 else self._held_out_draws(residuals, inputs, blocks))
        if isinstance(drawn, Calibration):
            return drawn
        thresholds = np.empty(self.n_joints)
        per_hour = 0.0
        over = 0
        for j in range(self.n_joints):
            values, duration, independent = drawn.of(j)
            duration *= period  # s per draw
            p = self.false_alarms_per_hour / SECONDS_PER_HOUR * duration / self.n_joints
            tail = Tail.fit(values, independent)
            thresholds[j] = max(tail.level(p), self.sigma * drawn.spread[j])
            per_hour += tail.exceedance(thresholds[j]) / duration * SECONDS_PER_HOUR
            over += int(np.count_nonzero(values > thresholds[j]))
        lo = hi = None
        parts = [] if drawn.inputs is None else [drawn.inputs]
        if self.calibrate_on == A_PRIORI and inputs is not None:  # the held-out motion too
            held = np.asarray(inputs, dtype=float)
            parts.append(held.reshape(-1, held.shape[-1]))
        parts = [part for part in parts if len(part)]
        if parts:  # the range of the finite values per input
            with np.errstate(invalid='ignore'):
                low = np.fmin.reduce([np.fmin.reduce(part, axis=0) for part in parts])
                high = np.fmax.reduce([np.fmax.reduce(part, axis=0) for part in parts])
        if parts and np.all(np.isfinite(low) & np.isfinite(high)):
            widen = self.envelope_margin * (high - low)
            lo, hi = low - widen, high + widen
            if not self.envelope_acceleration:  # q'', the last n inputs: not bounded
                lo[-self.n_joints:], hi[-self.n_joints:] = -np.inf, np.inf
        why = ''
        if nmse is None:
            why = 'no validation NMSE yet'
        elif nmse >= self.arm_nmse:
            why = f'validation NMSE {nmse:.3g} >= {self.arm_nmse:g}'
        elif not np.all(np.isfinite(thresholds) & (thresholds > 0)):
            why = 'a threshold is not positive and finite'
        elif per_hour > self.false_alarms_per_hour * (1.0 + 1e-9):  # rounding
            why = (f'estimated {per_hour:.3g} false alarms/h > '
                   f'{self.false_alarms_per_hour:g}')
        elif over:
            why = f'{over} calibration draws over their thresholds'
        return Calibration(segments=drawn.segments, independent=drawn.fewest,
                           correlation_samples=drawn.tau, centre=drawn.centre,
                           thresholds=thresholds, false_alarms_per_hour=per_hour, over=over,
                           why_not=why, lo=lo, hi=hi)

    def _deviation(self, r: NDArray[np.float64], centre: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
        """|r − centre| of residuals (..., L, n), as its running minimum over
        ``min_samples`` samples along L when an alarm needs more than one in a row."""
        deviation = np.abs(r - centre)
        if self.min_samples > 1:
            deviation = sliding_window_view(deviation, self.min_samples, axis=-2).min(axis=-1)
        return deviation

    def _held_out_draws(self, residuals: NDArray[np.float64] | None,
                        inputs: NDArray[np.float64] | None,
                        blocks: NDArray[np.int64] | None) -> _Draws | Calibration:
        """The held-out segments' draws (module docstring), or why there are too few."""
        if residuals is None:
            return Calibration(why_not='no held-out residuals yet')
        r = np.asarray(residuals, dtype=float)
        if r.ndim == 2:
            r = r[:, None, :]
        if r.ndim != 3 or r.shape[2] != self.n_joints:
            raise ValueError(f'residuals have shape {np.shape(residuals)}, the detector '
                             f'{self.n_joints} joints')
        finite = np.all(np.isfinite(r), axis=(1, 2))
        r = r[finite]
        count, length = r.shape[0], r.shape[1]
        if count < MIN_DRAWS or length < self.min_samples:
            return Calibration(segments=count, why_not=f'{count} held-out segments, need '
                               f'{MIN_DRAWS} independent ones')
        flat = r.reshape(-1, self.n_joints)
        centre = np.median(np.ascontiguousarray(flat.T), axis=1)
        tau = correlation_time(r)
        maxima = self._deviation(r, centre).max(axis=1)  # (K, n)
        x = None
        if inputs is not None:
            x = np.asarray(inputs, dtype=float)
            x = (x[:, None, :] if x.ndim == 2 else x)[finite].reshape(-1, x.shape[-1])
        draws = _Draws.of_segments(maxima, tau, length, None if blocks is None
                                   else np.asarray(blocks)[finite], centre,
                                   robust_spread(flat), x)
        if draws.fewest < MIN_DRAWS:
            return Calibration(segments=count, independent=draws.fewest,
                               correlation_samples=tau,
                               why_not=f'{draws.fewest:.0f} independent held-out draws, '
                               f'need {MIN_DRAWS}')
        return draws

    def _recent_draws(self, last: int) -> _Draws | Calibration:
        """The draws of the ``last`` a-priori residuals checked (module docstring), or why
        there are too few: joint j's maxima over consecutive runs of ``max(2τ_j,
        RECENT_DRAW)`` samples, τ_j measured within runs of :data:`RECENT_CHUNK`."""
        r, x = self._recent.window(last)
        count = len(r)
        if count < 2 * RECENT_CHUNK:
            return Calibration(segments=count // RECENT_DRAW,
                               why_not=f'{count} a-priori residuals, need {2 * RECENT_CHUNK}')
        finite = np.all(np.isfinite(r), axis=1)
        centre = np.nanmedian(np.ascontiguousarray(r.T), axis=1)
        spread = robust_spread(r[finite])
        chunks = count // RECENT_CHUNK
        r = np.where(np.isfinite(r), r, centre)  # no residual (or a contact's): no draw
        tau = correlation_time(r[count - chunks * RECENT_CHUNK:].reshape(
            chunks, RECENT_CHUNK, self.n_joints))
        deviation = self._deviation(r, centre)
        draws = _Draws.of_runs(deviation, np.maximum(2 * tau, RECENT_DRAW), tau, centre,
                               spread, x)
        if draws.fewest < MIN_DRAWS:
            return Calibration(segments=count // RECENT_DRAW, independent=draws.fewest,
                               correlation_samples=tau,
                               why_not=f'{draws.fewest:.0f} independent a-priori draws, '
                               f'need {MIN_DRAWS}')
        return draws

    def update_nmse(self, validation_nmse: float) -> None:
        """Take a fresh validation NMSE of the same model between calibrations: at or above
        ``arm_nmse`` (a model that got worse since) detection is disarmed until the next
        :meth:`calibrate` arms it again, so that the rule holds while armed, not only at
        the calibrations."""
        self.validation_nmse = float(validation_nmse)
        if self._active is not None and not validation_nmse < self.arm_nmse:
            self._active = None
            self.calibration = replace(
                self.calibration,
                why_not=f'validation NMSE {validation_nmse:.3g} >= {self.arm_nmse:g}')

    def observe(self, external: NDArray[np.float64],
                x: NDArray[np.float64] | None = None) -> None:
        """Keep a-priori residuals (K, n) (N·m or N) and their inputs (K, 3n) for the next
        :meth:`calibrate`, as :meth:`check` keeps each sample it checks (an offline
        stream, unchecked)."""
        r = np.atleast_2d(np.asarray(external, dtype=float))
        inputs = None if x is None else np.atleast_2d(np.asarray(x, dtype=float))
        if r.shape[1] != self.n_joints or (inputs is not None and len(inputs) != len(r)):
            raise ValueError(f'residuals of shape {r.shape} and inputs of shape '
                             f'{None if inputs is None else inputs.shape} for '
                             f'{self.n_joints} joints')
        for k in range(max(0, len(r) - len(self._recent.residuals)), len(r)):
            self._recent.add(r[k], None if inputs is None else inputs[k])

    def keep_recent(self, other: ContactDetector) -> None:
        """Take the a-priori residuals ``other`` has kept (a detector of new settings for
        the same model: its next calibration need not wait for a window of its own)."""
        if other.n_joints != self.n_joints:
            raise ValueError(f'a detector of {other.n_joints} joints, this one has '
                             f'{self.n_joints}')
        self._recent = other._recent.copy()

    def inside(self, x: NDArray[np.float64]) -> bool:
        """Whether an input [q, q', q''] (3n,) is within the calibrated envelope (True
        without one)."""
        envelope = self._envelope
        if envelope is None:
            return True
        lo, hi = envelope
        return bool(np.all((x >= lo) & (x <= hi)))

    def check(self, external: NDArray[np.float64],
              x: NDArray[np.float64] | None = None) -> NDArray[np.bool_]:
        """The joints in contact at one sample, from its τ_ext (n,) (N·m or N) and its input
        x (3n,) (optional: the envelope check): shape (n,).

        All False while not armed, and for a sample outside the envelope (counted in
        ``held``; the run counts start again); a non-finite τ_ext is not over.
        """
        active = self._active
        if active is None or (x is not None and not self.inside(x)):
            if active is not None:
                self.held += 1
            self._over[:] = 0
            self._recent.add(external, x)
            return np.zeros(self.n_joints, dtype=bool)
        centre, thresholds = active
        over: NDArray[np.bool_] = np.abs(external - centre) > thresholds  # NaN: False
        if self.min_samples > 1:
            self._over += 1
            self._over[~over] = 0
            over = np.asarray(self._over >= self.min_samples)
        # a contact's residual is not the free motion's: not kept for calibration
        self._recent.add(np.where(over, np.nan, external) if over.any() else external, x)
        return over

    def reset(self) -> None:
        """Forget the calibration, the NMSE and the runs (a new model)."""
        self.calibration = Calibration()
        self.validation_nmse = None
        self._active = None
        self._envelope = None
        self.held = 0
        self._over[:] = 0
        self._recent.clear()
