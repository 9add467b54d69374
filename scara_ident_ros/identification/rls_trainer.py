"""Online learning of a physical model: recursive least squares, one sample at a time.

The :class:`~scara_ident_ros.identification.trainer.Trainer` of a
:class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel`: each sample is predicted
with the current θ (the a-priori prediction the identifier publishes and scores), then its
regressor rows enter the :class:`~scara_ident_ros.dynamics.recursive_least_squares.
RecursiveLeastSquares` and the model takes the new θ. After any number of samples the model
holds the least-squares fit of all of them (up to the weak prior), so frozen it predicts
every motion it has seen as a batch fit would: identification, not tracking.

A model fitted offline (``scara-ident train --method physical``) goes on from its θ (the
prior mean); ``p0`` sets how little that prior weighs against the stream.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.dynamics.recursive_least_squares import RecursiveLeastSquares

__all__ = ['RecursiveLeastSquaresTrainer']


class RecursiveLeastSquaresTrainer:
    """Predict a sample a priori with the physical model, then take it into RLS.

    Parameters
    ----------
    model : PhysicalModel
        The model learnt, in place (its :attr:`~PhysicalModel.theta` follows RLS).
    p0 : float
        Prior covariance p0 · I of θ around the model's current θ.

    Attributes
    ----------
    rls : RecursiveLeastSquares
        The estimator (its ``count`` is the samples learnt).
    """

    def __init__(self, model: PhysicalModel, *, p0: float = 1e6) -> None:
        self.model = model
        self.rls = RecursiveLeastSquares(model, p0=p0, theta0=model.theta)

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the prediction of ``y`` (n,) from ``x`` (3n,) made before learning it.

        Raises
        ------
        ValueError
            If ``x`` or ``y`` is not finite or has the wrong size; nothing was learnt.
        """
        prediction, _ = self.learn_rows(x, y)
        return prediction

    def learn_rows(self, x: NDArray[np.float64], y: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`learn`, also returning the sample's regressor rows h (n, p): τ = h θ."""
        n = self.model.n_joints
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        y = np.asarray(y, dtype=np.float64).reshape(-1)
        if x.shape != (3 * n,) or y.shape != (n,):
            raise ValueError(f'need x of shape ({3 * n},) and y of shape ({n},), got '
                             f'{x.shape} and {y.shape}')
        h = self.model.regressor(x[:n], x[n:2 * n], x[2 * n:])  # (n, p)
        prediction = h @ self.model.theta
        self.rls.update_rows(h, y)
        self.model.theta = self.rls.theta
        return prediction, h
