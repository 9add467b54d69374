"""The Coulomb friction shape of a physical model, chosen on validation data.

A robot's Coulomb friction changes sign with q', but how sharply depends on the drive:
sign(q') is the ideal step, tanh(q'/ε) a smooth one, and the q'' estimated from q' blurs
any step over the estimate's window. The held-out error depends on matching that
sharpness: measured on two simulated robots whose friction steps differ
(benchmarks/physical.md), the best fixed shape of one is several times worse than the best
on the other, by orders of magnitude for sign on the smooth one. No single shape is right
for every robot, so the fit tries each of :data:`CANDIDATES` by least squares on the
training samples and keeps the one of lowest mean validation NMSE: a few more linear
fits.

Public API::

    CANDIDATES                            (coulomb, ε) pairs tried
    CoulombChoice                         coulomb, eps, scores
    select_coulomb(build, train, validation) -> (PhysicalModel, CoulombChoice)
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

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
                   candidates: tuple[tuple[str, float], ...] = CANDIDATES,
                   ) -> tuple[PhysicalModel, CoulombChoice]:
    """Fit a model per Coulomb shape; keep the best on validation.

    Parameters
    ----------
    build : callable
        ``build(coulomb, eps)`` returns a fresh model of that shape.
    train, validation : (X, Y)
        Inputs (N, 3n) = [q, q', q''] and efforts (N, n); validation not empty.
    candidates : tuple of (str, float)
        Shapes to try.

    Returns
    -------
    model : PhysicalModel
        The best model, fitted on ``train``.
    choice : CoulombChoice
    """
    xv = np.asarray(validation[0], dtype=np.float64)
    yv = np.asarray(validation[1], dtype=np.float64)
    if xv.shape[0] < 2:
        raise ValueError('choosing the Coulomb shape needs validation samples')
    variance = np.where(yv.var(axis=0) > 0.0, yv.var(axis=0), 1.0)
    best: tuple[float, PhysicalModel, str, float] | None = None
    scores: dict[str, float] = {}
    for coulomb, eps in candidates:
        model = build(coulomb, eps).fit_inputs(*train)
        score = float(np.mean(np.mean((model.predict(xv) - yv) ** 2, axis=0) / variance))
        scores[_label(coulomb, eps)] = score
        if best is None or score < best[0]:
            best = (score, model, coulomb, eps)
    assert best is not None
    return best[1], CoulombChoice(best[2], best[3], scores)


def _label(coulomb: str, eps: float) -> str:
    return 'sign' if coulomb == 'sign' else f'tanh {eps:g}'
