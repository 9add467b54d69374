"""Zero-lag joint acceleration: a local polynomial fitted around each sample.

The causal estimates of :class:`~scara_ident_ros.identification.Differentiator` lag the true
q'' (the 50 Hz low-pass by a few milliseconds), and a model learnt from them learns that lag
with the dynamics: least squares on the SCARA's physical regressor, exact with the true q'',
is far from exact with the low-pass estimate (docs/results.md). A learning target does not have
to be causal: the identifier can wait a few samples. This estimate fits a polynomial of
degree ``p`` to the ``W = 2m + 1`` velocities centred on a sample, at their actual stamps,
and differentiates it at that sample, so it is

- exact for velocities that are polynomials of degree up to ``p`` (any stamps);
- zero-phase for uniform stamps (the weights are antisymmetric), hence no lag;
- available ``m`` samples late (``m`` ms at 1 kHz with the default ``W = 21``);
- quiet: with uniform period ``T`` and ``p`` = 2, white velocity noise of std ``s`` gives
  acceleration noise ``s / T * sqrt(12 / (m (m + 1) (2m + 1)))`` (0.072 s/T for W = 21),
  where the backward difference gives ``1.41 s / T``.

Near the ends of a history (the first and last ``m`` samples before a restart) the same fit
over the first or last ``W`` samples is evaluated off-centre: still exact on polynomials,
noisier. A history of fewer than ``W`` samples gives no estimate.

For a signal of frequency ``f`` the relative error of the centred slope is about
``(2 pi f m T)^2 / 10``: 0.4 % at 3 Hz for W = 21 at 1 kHz.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ['CentredDifferentiator', 'DIFFERENTIATOR_WINDOW', 'WINDOW_S', 'recording_window']

NS = 1e-9  # seconds per nanosecond
#: Samples of the default fit, here and of the identifier's ``window`` parameter.
DIFFERENTIATOR_WINDOW = 21
#: The shortest span (s) of a recording's fit: the default window's at 1 kHz.
WINDOW_S = 0.020


def recording_window(stamp_ns: NDArray[np.int64]) -> int:
    """The fit's window for a recording of these stamps (N,): at least
    :data:`DIFFERENTIATOR_WINDOW` samples and at least :data:`WINDOW_S` of its median step,
    odd. A window in samples spans less time the faster the recording: at 5 kHz 21 samples
    are 4 ms, and the TX40's q' and q'' over them were noisy enough to raise its physical
    model's held-out NMSE on joints 2 and 3 from 0.034 and 0.031 (101 samples, 20 ms) to 0.048
    and 0.057 (benchmarks/later_motion.md). 1 kHz and slower recordings keep 21.
    """
    steps = np.diff(np.sort(np.asarray(stamp_ns, dtype=np.int64)))
    steps = steps[steps > 0]
    if not steps.size:
        return DIFFERENTIATOR_WINDOW
    samples = int(np.ceil(WINDOW_S / (float(np.median(steps)) * NS)))
    return max(DIFFERENTIATOR_WINDOW, samples + 1 - samples % 2)


class CentredDifferentiator:
    """q'' of a sample from a polynomial fitted to the W velocities around it.

    Stateless: the caller keeps the history (see
    :class:`~scara_ident_ros.identification.InputStage`).

    Parameters
    ----------
    window : int
        Odd number of samples ``W = 2m + 1`` per fit, at least ``degree + 2``.
    degree : int
        Degree ``p`` of the polynomial, at least ``order``.
    order : int
        Which derivative of the fit: 1 (the slope: q'' of velocities, q' of positions) or 2
        (q'' of positions, when a stream carries no velocity).
    """

    method = 'centred'

    def __init__(self, window: int = DIFFERENTIATOR_WINDOW, degree: int = 2,
                 order: int = 1) -> None:
        if order not in (1, 2) or degree < order or window < degree + 2 or window % 2 == 0:
            raise ValueError(f'a centred fit needs an odd window >= degree + 2 and degree >= '
                             f'order (1 or 2), got window {window}, degree {degree}, order '
                             f'{order}')
        self.window = int(window)
        self.degree = int(degree)
        self.order = int(order)
        self._cache_key: object = None
        self._cache_weights = np.empty((0, self.window))

    @property
    def lag(self) -> int:
        """Samples m after a sample that its estimate needs: (W - 1) / 2."""
        return self.window // 2

    def delay(self, period_s: float) -> float:
        """Lag of the estimate behind the true q'' (s): 0, as for any zero-phase estimate.

        The estimate is *available* ``lag · period_s`` after its sample; see :attr:`lag`.
        """
        return 0.0

    def derivative(self, stamp_ns: NDArray[np.int64], velocity: NDArray[np.float64],
                   at: int | slice) -> NDArray[np.float64]:
        """Differentiate the fit of all the given samples at the samples ``at``.

        Parameters
        ----------
        stamp_ns : ndarray of shape (W,) of int64
            Increasing stamps of the fitted samples, integer nanoseconds.
        velocity : ndarray of shape (W, n)
            Their velocities q' (rad/s or m/s).
        at : int or slice
            Index or indices (into the W samples) where the derivative is wanted; the centre
            ``lag`` for an ordinary sample.

        Returns
        -------
        ndarray of shape (n,) for an int ``at``, (k, n) for a slice
            Accelerations q'' (rad/s² or m/s²).
        """
        weights = self.weights(stamp_ns, at)
        acc = weights @ velocity
        return acc[0] if isinstance(at, (int, np.integer)) else acc

    def weights(self, stamp_ns: NDArray[np.int64], at: int | slice) -> NDArray[np.float64]:
        """Return the linear weights (k, W) that map the W velocities to q'' at ``at``.

        The weights depend only on the stamps' offsets; those of the last pattern are
        cached, so uniform stamps (a simulator, most drivers) cost one product per sample.
        """
        t = np.asarray(stamp_ns, dtype=np.int64)
        offsets = t - t[0]
        key = (offsets.tobytes(), at if isinstance(at, int) else (at.start, at.stop))
        if key == self._cache_key:
            return self._cache_weights
        half_span = max(float(offsets[-1]) / 2.0, 1.0)  # ns
        # Basis ((t_i - t_c) / half_span) ** j on [-1, 1]: well conditioned for any stamps.
        u = (offsets - float(offsets[offsets.shape[0] // 2])) / half_span
        basis = np.vander(u, self.degree + 1, increasing=True)  # (W, p + 1)
        fit = np.linalg.solve(basis.T @ basis, basis.T)  # (p + 1, W): coefficients' weights
        at_u = np.atleast_1d(u[at])
        # d^k/dt^k of sum_j c_j u^j = sum_(j>=k) j!/(j-k)! c_j u^(j-k) / half_span^k
        k = self.order
        powers = np.arange(k, self.degree + 1)
        factor = powers * (powers - 1) if k == 2 else powers
        slope_basis = factor * at_u[:, None] ** (powers - k)  # (k, p + 1 - order)
        weights = slope_basis @ fit[k:] / (half_span * NS) ** k
        self._cache_key, self._cache_weights = key, weights
        return weights

    def __repr__(self) -> str:
        order = f', order={self.order}' if self.order != 1 else ''
        return f'CentredDifferentiator(window={self.window}, degree={self.degree}{order})'

