"""The one path from joint-state samples to network inputs, online and offline.

Every sample goes through :class:`SampleCheck` (rejections, joint order, clock gaps), then
q'' is estimated from q' and the sample comes out as an :class:`Input`, ``x = [q, q', q'']``
with its measured effort. The identifier node, the CLI and the simulated experiments all
use this stage, so a network sees the same inputs whichever way it is trained.

With the default :class:`CentredDifferentiator` (zero-phase) a sample comes out ``lag``
samples after it went in; a clock gap or :meth:`InputStage.flush` lets the last samples of
a history out with an off-centre fit. The causal :class:`Differentiator` estimates have
``lag`` 0, with the filter's delay in q''.

A stream that carries no velocity (positions and efforts only, as the TX40's) gets q' from
its positions when ``derive_velocity`` is set: the centred estimate fits one polynomial of
degree ``p + 1`` to the W positions around a sample and takes q' and q'' from it (the same
window and lag as q'' from velocities, exact for polynomial q of that degree); a causal
estimate differentiates q with a copy of itself, then q' as usual (the two delays add). The
first accepted sample decides: if it has no velocity, every later one gets its q' derived
(a velocity given then is ignored); else a later sample without velocity is ``no_velocity``.
A centred window of 3 samples derives nothing (a fit of q for q'' needs degree 2 and 4
samples). Derived velocities are not checked against the velocity limits, and a sample whose q and
effort equal the last accepted one's is ``repeated``.

Counting: every sample pushed is, at any time, either rejected or dropped (``skipped``, per
:class:`SkipReason`), out (``emitted``) or still ``pending``; ``gaps`` counts the clock
gaps (forwards or a restarted clock) the accepted samples came after.
"""
from __future__ import annotations

import copy
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.centred_differentiator import CentredDifferentiator
from scara_ident_ros.identification.differentiator import AccelerationEstimate, Differentiator
from scara_ident_ros.identification.joint_map import JointMap
from scara_ident_ros.identification.sample_check import (DEFAULT_MAX_GAP_NS, Bounds,
                                                         FloatArrayLike, Sample, SampleCheck)
from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['Input', 'InputStage']

class Input(NamedTuple):
    """One network input with its target.

    Attributes
    ----------
    stamp_ns : int
        The sample's stamp (ns).
    x : ndarray of shape (3n,)
        ``[q_1..q_n, q'_1..q'_n, q''_1..q''_n]`` in joint order (rad or m, /s, /s²).
    effort : ndarray of shape (n,) or None
        Measured effort (N·m or N), None if the message had none.
    """

    stamp_ns: int
    x: NDArray[np.float64]
    effort: NDArray[np.float64] | None


class InputStage:
    """Joint-state samples in, network inputs out, in stamp order.

    Parameters
    ----------
    joint_map : JointMap
        The joint order (adopted from the first valid sample if it has none).
    need_effort : bool
        Reject samples without effort (see :class:`SampleCheck`).
    max_gap_ns, bounds
        As in :class:`SampleCheck`; a gap lets the history's last samples out and restarts
        the estimate.
    differentiator : AccelerationEstimate, optional
        The q'' estimate; default ``CentredDifferentiator(21, 2)``.
    derive_velocity : bool
        Derive q' from q when the stream carries no velocity (module docstring); False:
        such a sample is ``no_velocity``.
    """

    def __init__(self, joint_map: JointMap, *, need_effort: bool = True,
                 max_gap_ns: int = DEFAULT_MAX_GAP_NS,
                 differentiator: AccelerationEstimate | None = None,
                 bounds: Bounds | None = None, derive_velocity: bool = False) -> None:
        self.check = SampleCheck(joint_map, need_effort=need_effort, max_gap_ns=max_gap_ns,
                                 bounds=bounds)
        self.differentiator = (differentiator if differentiator is not None
                               else CentredDifferentiator())
        self.derive_velocity = bool(derive_velocity)
        self.deriving: bool | None = None  # whether q' is derived: set by the first sample
        diff = self.differentiator
        if isinstance(diff, CentredDifferentiator):
            degree = min(diff.degree + 1, diff.window - 2)  # a fit of q needs degree >= 2:
            self.derive_velocity &= degree >= 2  # a window of 3 derives nothing
            degree, window = max(degree, 2), max(diff.window, 5)  # (then unused)
            self._slope: AccelerationEstimate = CentredDifferentiator(window, degree)
            self._curvature = CentredDifferentiator(window, degree, order=2)
        else:
            slope = copy.deepcopy(diff)
            slope.reset()
            self._slope = slope
        self.skipped: dict[SkipReason, int] = dict.fromkeys(SkipReason, 0)
        self.emitted = 0
        self.gaps = 0  # accepted samples after a clock gap (each restarts the q'' estimate)
        self._history: list[Sample] = []  # centred: the last <= W accepted samples
        self._length = 0  # centred: samples in the current history, all told
        centred = isinstance(self.differentiator, CentredDifferentiator)
        window = self.differentiator.window if centred else 0
        self._stamps = np.zeros(window, dtype=np.int64)  # centred: last W stamps, newest last
        self._velocity = np.zeros((window, 0))  # centred: last W velocities (W, n)

    @property
    def lag(self) -> int:
        """Samples after a sample that its q'' needs (0 for a causal estimate)."""
        return self.differentiator.lag if isinstance(self.differentiator,
                                                     CentredDifferentiator) else 0

    @property
    def pending(self) -> int:
        """Samples accepted but not yet out (at most the window)."""
        if not isinstance(self.differentiator, CentredDifferentiator):
            return 0
        length = self._length
        return self.lag if length >= self.differentiator.window else length

    def push(self, stamp_ns: int, names: tuple[str, ...] | list[str], position: FloatArrayLike,
             velocity: FloatArrayLike, effort: FloatArrayLike = ()
             ) -> tuple[SkipReason | None, list[Input]]:
        """Take one sample; return why it was rejected (or None) and the inputs now ready.

        The sample is as in :meth:`SampleCheck.check`.

        Returns
        -------
        reason : SkipReason or None
            Why this sample was rejected (it then changed nothing), or, with a causal
            estimate, why it gave no input (``GAP``, ``WARMING_UP``).
        inputs : list of Input
            Samples whose input is now complete, oldest first (with a centred estimate the
            sample ``lag`` before this one, plus a history's rest at a gap).
        """
        derived = self.deriving
        if derived is None:
            derived = self.derive_velocity and len(velocity) == 0 and len(position) != 0
        if derived and len(position) != 0:
            velocity = np.zeros(len(position))  # a placeholder: q' comes from q
        sample = self.check.check(stamp_ns, names, position, velocity, effort)
        if isinstance(sample, SkipReason):
            self.skipped[sample] += 1
            return sample, []
        self.deriving = bool(derived)
        self.gaps += sample.gap
        if isinstance(self.differentiator, Differentiator):
            return self._push_causal(sample)
        out = self.flush() if sample.gap else []
        return None, out + self._push_centred(sample)

    def flush(self) -> list[Input]:
        """End the current history: let its pending samples out (off-centre fits).

        A history shorter than the window gives no estimate: its samples are counted as
        skipped ``WARMING_UP``. The next sample starts a new history.
        """
        if isinstance(self.differentiator, Differentiator):
            self.differentiator.reset()
            self._reset_slope()
            return []
        history, self._history, length, self._length = self._history, [], self._length, 0
        w, m = self.differentiator.window, self.lag
        if length < w:
            self.skipped[SkipReason.WARMING_UP] += length
            return []
        return self._emit(history, slice(m + 1, w))

    def reset(self) -> None:
        """Forget the last stamp and the history; pending samples are dropped (skipped)."""
        self.check.reset()
        if isinstance(self.differentiator, Differentiator):
            self.differentiator.reset()
            self._reset_slope()
        self.skipped[SkipReason.WARMING_UP] += self.pending
        self._history, self._length = [], 0

    def batch(self, stamp_ns: NDArray[np.int64], names: tuple[str, ...],
              position: NDArray[np.float64], velocity: NDArray[np.float64],
              effort: NDArray[np.float64] | None = None
              ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Push a whole recording, in stamp order, then flush: the offline path.

        Parameters
        ----------
        stamp_ns : ndarray of shape (N,) of int64
            Stamps (ns) in any order (taken sorted, stable).
        names : tuple of str of length n
            The joints of the columns.
        position, velocity : ndarray of shape (N, n)
            q and q' (a NaN rejects the sample).
        effort : ndarray of shape (N, n), optional
            Measured efforts; None (or 0 columns) if not recorded.

        Returns
        -------
        stamp_ns : ndarray of shape (K,) of int64
            Stamps of the samples that came out, increasing.
        X : ndarray of shape (K, 3n)
            Their inputs ``[q, q', q'']`` in the stage's joint order.
        Y : ndarray of shape (K, n)
            Their efforts (NaN rows for samples without one).
        """
        no_effort: tuple[float, ...] = ()
        efforts = effort if effort is not None and effort.ndim == 2 and effort.shape[1] else None
        inputs: list[Input] = []
        for i in np.argsort(stamp_ns, kind='stable').tolist():
            inputs += self.push(int(stamp_ns[i]), names, position[i], velocity[i],
                                efforts[i] if efforts is not None else no_effort)[1]
        inputs += self.flush()
        k = len(inputs)
        n = len(names)
        X = np.empty((k, 3 * n))
        Y = np.full((k, n), np.nan)
        for row, item in enumerate(inputs):
            X[row] = item.x
            if item.effort is not None:
                Y[row] = item.effort
        stamps = np.fromiter((item.stamp_ns for item in inputs), dtype=np.int64, count=k)
        return stamps, X, Y

    # ---------------------------------------------------------------- internals
    def _reset_slope(self) -> None:
        """Restart the causal q' estimate of a stream without velocities."""
        if isinstance(self._slope, Differentiator):
            self._slope.reset()

    def _push_causal(self, sample: Sample) -> tuple[SkipReason | None, list[Input]]:
        diff = self.differentiator
        assert isinstance(diff, Differentiator)
        if sample.gap:
            diff.reset()
            self._reset_slope()
        velocity: NDArray[np.float64] | None = sample.velocity
        if self.deriving:
            assert isinstance(self._slope, Differentiator)
            velocity = self._slope.update(sample.stamp_ns, sample.position)
            if velocity is not None:
                sample = sample._replace(velocity=velocity)
        acceleration = (diff.update(sample.stamp_ns, sample.velocity) if velocity is not None
                        else None)
        if acceleration is None:
            reason = SkipReason.GAP if sample.gap else SkipReason.WARMING_UP
            self.skipped[reason] += 1
            return reason, []
        self.emitted += 1
        return None, [Input(sample.stamp_ns,
                            np.concatenate((sample.position, sample.velocity, acceleration)),
                            sample.effort)]

    def _push_centred(self, sample: Sample) -> list[Input]:
        diff = self.differentiator
        assert isinstance(diff, CentredDifferentiator)
        w, m = diff.window, diff.lag
        history = self._history
        history.append(sample)
        if len(history) > w:
            del history[0]
        if self._velocity.shape[1] != sample.velocity.shape[0]:
            self._velocity = np.zeros((w, sample.velocity.shape[0]))
        # Newest last: shift by one (W rows, cheaper than a deque turned into arrays).
        self._stamps[:-1] = self._stamps[1:]
        self._stamps[-1] = sample.stamp_ns
        self._velocity[:-1] = self._velocity[1:]
        self._velocity[-1] = sample.position if self.deriving else sample.velocity
        self._length += 1
        if self._length < w:
            return []
        # The first full window lets out its first half too (off-centre), then its centre.
        return self._emit(history, slice(0, m + 1) if self._length == w else slice(m, m + 1))

    def _emit(self, history: list[Sample], at: slice) -> list[Input]:
        diff = self.differentiator
        assert isinstance(diff, CentredDifferentiator)
        w = len(history)
        stamps, signal = self._stamps[-w:], self._velocity[-w:]
        samples = history[at]
        if self.deriving:  # signal holds positions: q' and q'' from one fit of them
            assert isinstance(self._slope, CentredDifferentiator)
            velocity = self._slope.derivative(stamps, signal, at)
            samples = [sample._replace(velocity=v) for sample, v in zip(samples, velocity)]
            acceleration = self._curvature.derivative(stamps, signal, at)
        else:
            acceleration = diff.derivative(stamps, signal, at)
        out = []
        for sample, acc in zip(samples, acceleration):
            out.append(Input(sample.stamp_ns,
                             np.concatenate((sample.position, sample.velocity, acc)),
                             sample.effort))
        self.emitted += len(out)
        return out
