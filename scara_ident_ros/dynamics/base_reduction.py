"""Base parameters of a linear-in-parameters model, found numerically (QR with pivoting).

The joint efforts of a rigid-body robot are linear in its standard parameters,
τ = W(q, q', q'') θ, but not every column of W is independent: a parameter that never moves
an effort (a link's inertia about an axis its joint cannot turn) gives a zero column, and
some parameters only act in fixed combinations (the masses of the links carried by a
prismatic joint). The efforts identify the *base parameters*, a minimal set of such
combinations.

The standard numerical reduction (Gautier, 1990): stack W over random states into
W_s (K·n × P), factor W_s Π = Q R with column pivoting, take the rank r as the number of
diagonal entries |R_ii| > ``tol``·|R_00|, keep the first r pivoted columns (independent)
and express the rest through them, W_dep = W_ind β with β = R₁₁⁻¹ R₁₂. Then

    W θ = W_ind (θ_ind + β θ_dep) = W_ind θ_b,

so the base regressor is W_ind and each base parameter is its independent parameter plus
the listed multiples of dependent ones (:meth:`BaseReduction.definitions`). Columns that are
zero on every state are dependent with β = 0 (unidentifiable, their values drop out).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

__all__ = ['BaseReduction', 'reduce_columns', 'RANK_TOLERANCE']

#: Relative size of R's diagonal below which a pivoted column counts as dependent. Exact
#: dependences leave ~1e-15; genuine columns of a well-excited stack stay above 1e-6.
RANK_TOLERANCE = 1e-8


@dataclass(frozen=True)
class BaseReduction:
    """Which standard parameters are independent, and how the others combine into them.

    Attributes
    ----------
    names : tuple of str of length P
        Names of the standard parameters (the columns of the full regressor).
    independent : ndarray of shape (r,) of int
        Columns kept, in pivot order (the base parameters' order).
    dependent : ndarray of shape (P − r,) of int
        The other columns.
    beta : ndarray of shape (r, P − r)
        W[:, dependent] = W[:, independent] @ beta on every state.
    """

    names: tuple[str, ...]
    independent: NDArray[np.int64]
    dependent: NDArray[np.int64]
    beta: NDArray[np.float64]

    def __post_init__(self) -> None:
        p = len(self.names)
        both = np.concatenate([self.independent, self.dependent])
        if sorted(both.tolist()) != list(range(p)):
            raise ValueError(f'independent and dependent columns must partition 0..{p - 1}')
        if self.beta.shape != (self.independent.size, self.dependent.size):
            raise ValueError(f'beta must have shape ({self.independent.size}, '
                             f'{self.dependent.size}), got {self.beta.shape}')

    @property
    def n_base(self) -> int:
        """Number of base parameters r."""
        return int(self.independent.size)

    @property
    def base_names(self) -> tuple[str, ...]:
        """Each base parameter named after its independent standard parameter."""
        return tuple(self.names[i] for i in self.independent)

    def base_values(self, theta: ArrayLike) -> NDArray[np.float64]:
        """θ_b = θ_ind + β θ_dep of standard parameters ``theta`` (P,); shape (r,)."""
        full = np.asarray(theta, dtype=np.float64)
        return full[self.independent] + self.beta @ full[self.dependent]

    def reduce(self, full_regressor: NDArray[np.float64]) -> NDArray[np.float64]:
        """The base regressor: the independent columns of ``full_regressor`` (..., P)."""
        return full_regressor[..., self.independent]

    def definitions(self, *, threshold: float = 1e-10) -> tuple[str, ...]:
        """What each base parameter is, e.g. ``'link2.Izz + 0.0625 quill.m'``.

        Parameters
        ----------
        threshold : float
            Multiples of dependent parameters smaller than this are left out.
        """
        rows = []
        for k, i in enumerate(self.independent):
            text = self.names[i]
            for j, factor in zip(self.dependent, self.beta[k]):
                if abs(factor) > threshold:
                    sign = '-' if factor < 0 else '+'
                    text += f' {sign} {abs(factor):.6g} {self.names[j]}'
            rows.append(text)
        return tuple(rows)


def reduce_columns(stacked: ArrayLike, names: Sequence[str], *,
                   tol: float = RANK_TOLERANCE) -> BaseReduction:
    """Find the independent columns of a stacked regressor (module docstring).

    ``stacked`` (K·n, P) is the full regressor at K random states, ``names`` its P column
    names, ``tol`` the rank tolerance relative to the largest diagonal entry of R.
    """
    w = np.asarray(stacked, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] != len(names):
        raise ValueError(f'need a stacked regressor of shape (rows, {len(names)}), got '
                         f'{w.shape}')
    if w.shape[0] < w.shape[1]:
        raise ValueError(f'{w.shape[0]} rows cannot rank {w.shape[1]} columns: stack more '
                         'states')
    _, r, pivots = scipy.linalg.qr(w, mode='economic', pivoting=True)
    diagonal = np.abs(np.diag(r))
    rank = int(np.count_nonzero(diagonal > tol * diagonal[0])) if diagonal[0] > 0 else 0
    independent = pivots[:rank].astype(np.int64)
    dependent = pivots[rank:].astype(np.int64)
    beta = (scipy.linalg.solve_triangular(r[:rank, :rank], r[:rank, rank:])
            if rank else np.zeros((0, dependent.size)))
    beta[np.abs(beta) < 1e-12] = 0.0  # rounding of exact zeros
    return BaseReduction(tuple(names), independent, dependent, beta)
