"""The Coulomb friction shape of a physical model, chosen on validation data.

A robot's Coulomb friction changes sign with q', but how sharply depends on the drive:
sign(q') is the ideal step, tanh(q'/ε) a smooth one, and the q'' estimated from q' blurs
any step over the estimate's window. The held-out error depends on matching that
sharpness: on two simulated robots whose friction steps differ, the best fixed shape of one
is far worse than the best on the other (benchmarks/physical.md). No single shape is right
for every robot, so the fit tries each of :data:`CANDIDATES` by least squares on the
training samples and keeps the one of lowest mean validation NMSE: a few more linear
fits.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from scara_ident_ros.dynamics.least_squares import BlockLeastSquares
from scara_ident_ros.dynamics.physical_model import PhysicalModel

__all__ = ['CANDIDATES', 'CoulombChoice', 'select_coulomb']

#: Shapes tried: sign, and tanh(q'/ε) for ε in rad/s (m/s for a prismatic joint).
CANDIDATES: tuple[tuple[str, float], ...] = (('sign', 1.0), ('tanh', 0.005), ('tanh', 0.01),
                                             ('tanh', 0.02), ('tanh', 0.05), ('tanh', 0.1),
                                             ('tanh', 0.2))


@dataclass(frozen=True)
class CoulombChoice:
    """The Coulomb shape kept, and every candidate's validation score.

    Attributes
    ----------
    coulomb : str
        ``'sign'`` or ``'tanh'``.
    eps : float
        ε of tanh(q'/ε) (unused with sign).
    scores : dict of str to float
        Candidate label (``'sign'``, ``'tanh 0.05'``) → mean validation NMSE over joints.
    """

    coulomb: str
    eps: float
    scores: dict[str, float]

    @property
    def label(self) -> str:
        """``'sign'`` or ``'tanh <eps>'``."""
        return _label(self.coulomb, self.eps)


def select_coulomb(build: Callable[[str, float], PhysicalModel],
                   train: tuple[ArrayLike, ArrayLike], validation: tuple[ArrayLike, ArrayLike],
                   candidates: tuple[tuple[str, float], ...] = CANDIDATES, *,
                   block: int = 2048) -> tuple[PhysicalModel, CoulombChoice]:
    """Fit a model per Coulomb shape; keep the best on validation.

    The candidates differ in their Coulomb column only: the rigid-body regressor (the
    costly part, one Pinocchio call per sample) is computed once per block and shared.

    Parameters
    ----------
    build : callable
        ``build(coulomb, eps)`` returns a fresh model of that shape, of one URDF and joints.
    train, validation : (X, Y)
        Inputs (N, 3n) = [q, q', q''] and efforts (N, n); validation not empty.
    candidates : tuple of (str, float)
        Shapes to try.
    block : int
        Samples per block.

    Returns
    -------
    model : PhysicalModel
        The best model, fitted on ``train`` (``theta`` and ``residual_rms`` set).
    choice : CoulombChoice
    """
    x, y = (np.asarray(a, dtype=np.float64) for a in train)
    xv, yv = (np.asarray(a, dtype=np.float64) for a in validation)
    if xv.shape[0] < 2:
        raise ValueError('choosing the Coulomb shape needs validation samples')
    models = [build(coulomb, eps) for coulomb, eps in candidates]
    first, n = models[0], models[0].n_joints
    if any(m.standard_names != first.standard_names
           or not np.array_equal(m.reduction.independent, first.reduction.independent)
           for m in models):
        raise ValueError('the candidates must be models of one URDF and joints')
    systems = [BlockLeastSquares(m.n_parameters) for m in models]
    for start in range(0, x.shape[0], block):
        part = x[start:start + block]
        base = first.base_regressor(part[:, :n], part[:, n:2 * n], part[:, 2 * n:])
        for model, system in zip(models, systems):
            system.add(model.regressor_from_base(base, part[:, n:2 * n]),
                       y[start:start + block])
    for model, system in zip(models, systems):
        model.set_theta(system.solve())
    squares = np.zeros((len(models), n))
    for start in range(0, xv.shape[0], block):
        part = xv[start:start + block]
        base = first.base_regressor(part[:, :n], part[:, n:2 * n], part[:, 2 * n:])
        for k, model in enumerate(models):
            error = model.regressor_from_base(base, part[:, n:2 * n]) @ model.theta
            squares[k] += np.sum((error - yv[start:start + block]) ** 2, axis=0)
    variance = np.where(yv.var(axis=0) > 0.0, yv.var(axis=0), 1.0)
    score = np.mean(squares / xv.shape[0] / variance, axis=1)
    scores = {_label(c, e): float(v) for (c, e), v in zip(candidates, score)}
    best = int(np.argmin(score))
    coulomb, eps = candidates[best]
    return (models[best].fit(x, y),  # the same θ, and its residual_rms
            CoulombChoice(coulomb, eps, scores))


def _label(coulomb: str, eps: float) -> str:
    return 'sign' if coulomb == 'sign' else f'tanh {eps:g}'
