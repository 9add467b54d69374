"""Contact detection from an identified model: measured − predicted effort over a threshold.

A model of the free robot's inverse dynamics predicts the effort the joints need for the
motion measured; an external effort (a contact, a collision) shows as the part of the
measured effort it does not explain, the *external torque* ``τ_ext = measured − predicted``.
That residual is also the model's error, so a joint's threshold is a multiple
(``sigma``) of the robust spread of the residuals on samples the model never learnt (the
held-out validation samples, :class:`~scara_ident_ros.identification.holdout.Holdout`):
``threshold_j = sigma · 1.4826 · MAD_j``, the median absolute deviation scaled to a
Gaussian's standard deviation, which a few large errors do not inflate.

Detection is armed only once the model identifies: its validation NMSE (the mean over the
joints) is below ``arm_nmse``. Before that the residual is mostly the model's error, and
thresholds from it would either never fire or fire all the time.

A joint is in contact when ``|τ_ext_j|`` exceeds its threshold for ``min_samples``
consecutive samples (1: at once); a longer run filters single-sample spikes at the cost of
``min_samples − 1`` samples of delay.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ['MAD_TO_SIGMA', 'ContactDetector', 'robust_spread']

MAD_TO_SIGMA = 1.4826  # a Gaussian's standard deviation over its median absolute deviation
MIN_RESIDUALS = 100  # held-out samples before thresholds are drawn from them


def robust_spread(residuals: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-joint robust standard deviation of residuals (K, n): 1.4826 · MAD, shape (n,).

    Rows with a non-finite value are left out; a joint without any finite residual is NaN.
    """
    r = np.asarray(residuals, dtype=float)
    if r.ndim != 2:
        raise ValueError(f'residuals must have shape (K, n), got {r.shape}')
    r = r[np.all(np.isfinite(r), axis=1)]
    if r.shape[0] == 0:
        return np.full(r.shape[1], np.nan)
    deviation = np.abs(r - np.median(r, axis=0))
    return np.asarray(MAD_TO_SIGMA * np.median(deviation, axis=0))


class ContactDetector:
    """Per-joint thresholds from held-out residuals, the arming rule, and the check.

    ``sigma``, ``arm_nmse`` and ``min_samples`` are as in the module docstring.

    Attributes
    ----------
    thresholds : ndarray of shape (n,) or None
        |τ_ext| per joint (N·m or N) above which a joint is in contact; None until
        :meth:`calibrate` has had enough residuals.
    validation_nmse : float or None
        The validation NMSE of the latest :meth:`calibrate`.
    """

    def __init__(self, n_joints: int, *, sigma: float = 12.0, arm_nmse: float = 0.01,
                 min_samples: int = 1) -> None:
        if n_joints < 1:
            raise ValueError(f'n_joints must be at least 1, got {n_joints}')
        if not (math.isfinite(sigma) and sigma > 0):
            raise ValueError(f'contact sigma must be > 0, got {sigma}')
        if not (math.isfinite(arm_nmse) and arm_nmse > 0):
            raise ValueError(f'contact arm NMSE must be > 0, got {arm_nmse}')
        if min_samples < 1:
            raise ValueError(f'contact min_samples must be at least 1, got {min_samples}')
        self.n_joints = n_joints
        self.sigma = float(sigma)
        self.arm_nmse = float(arm_nmse)
        self.min_samples = int(min_samples)
        self.thresholds: NDArray[np.float64] | None = None
        self.validation_nmse: float | None = None
        self._over = np.zeros(n_joints, dtype=np.int64)  # consecutive samples over, per joint
        self._active: NDArray[np.float64] | None = None  # the thresholds while armed

    @property
    def armed(self) -> bool:
        """Whether detection is on: thresholds known and the validation NMSE below
        ``arm_nmse``."""
        return (self.thresholds is not None and self.validation_nmse is not None
                and self.validation_nmse < self.arm_nmse)

    def calibrate(self, residuals: NDArray[np.float64] | None,
                  validation_nmse: float | None) -> None:
        """Take the current model's held-out residuals (K, n) (N·m or N) and validation NMSE.

        With fewer than 100 residuals, a non-finite NMSE or a joint whose spread is not
        positive and finite, the detector is disarmed (thresholds None).
        """
        nmse = None if validation_nmse is None or not math.isfinite(validation_nmse) \
            else float(validation_nmse)
        self.validation_nmse = nmse
        self.thresholds = None
        if residuals is not None and len(residuals) >= MIN_RESIDUALS and nmse is not None:
            spread = robust_spread(residuals)
            if spread.shape != (self.n_joints,):
                raise ValueError(f'residuals have {spread.shape[0]} joints, the detector '
                                 f'{self.n_joints}')
            if np.all(np.isfinite(spread) & (spread > 0)):
                self.thresholds = self.sigma * spread
        self._active = self.thresholds if self.armed else None

    def check(self, external: NDArray[np.float64]) -> NDArray[np.bool_]:
        """The joints in contact at one sample, from its τ_ext (n,) (N·m or N): shape (n,).

        All False while not armed (and the run counts start again); a non-finite τ_ext is
        not over the threshold.
        """
        thresholds = self._active
        if thresholds is None:
            self._over[:] = 0
            return np.zeros(self.n_joints, dtype=bool)
        over: NDArray[np.bool_] = np.abs(external) > thresholds  # NaN compares False
        if self.min_samples == 1:
            return over
        self._over += 1
        self._over[~over] = 0
        return np.asarray(self._over >= self.min_samples)

    def reset(self) -> None:
        """Forget the thresholds, the NMSE and the runs (a new model)."""
        self.thresholds = None
        self.validation_nmse = None
        self._active = None
        self._over[:] = 0
