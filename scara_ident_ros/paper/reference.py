"""The model-based reference row: least squares on the SCARA's linear-in-parameters model.

:class:`~scara_ident_ros.dynamics.LeastSquaresIdentifier` fits the 14 base parameters
(inertial, gravity, viscous and Coulomb friction) of τ = Y(q, q', q'') θ in closed form. It
knows the model's structure, which the networks do not; on noise-free simulated data with the
true q'' it reproduces the efforts to rounding error, so it is both the bar the networks are
measured against and a check of the whole data pipeline.

Offline, it is fitted on the networks' training samples. Online, it has no per-sample form
here: it is fitted in one batch on the stream *before* the evaluation windows and evaluated on
them (samples it has not seen, like the networks' a-priori errors) and on the other data
sets.

It is the SCARA's model, so it is added only for the SCARA, not for any 4-joint robot:
:func:`is_scara` says whether joint names and positions can be the SCARA's.
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from scara_ident_ros.dynamics import LeastSquaresIdentifier, ScaraParams
from scara_ident_ros.paper.datasets import Evaluations
from scara_ident_ros.identification.error_window import recent_errors
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.table3 import DEFAULT_WINDOW, stream_data_names
from scara_ident_ros.paper.rows import REFERENCE, ResultRow
from scara_ident_ros.identification import PAPER_WINDOW

__all__ = ['ReferenceFit', 'fit_reference', 'is_scara', 'online_reference_rows',
           'predict_reference', 'reference_rows']

FloatArray = npt.NDArray[np.float64]

_N_JOINTS = 4
#: Positions may pass the SCARA's joint limits by this fraction of each joint's range.
LIMIT_MARGIN = 0.05


def is_scara(names: Sequence[str], X: npt.ArrayLike, params: ScaraParams | None = None
             ) -> bool:
    """Whether joint states can be those of the SCARA whose regressor the reference fits.

    True when the joints carry the SCARA's names in its order (``params.joint_names``) and
    every position lies within its joint limits, give or take ``LIMIT_MARGIN`` of each
    range (joint3, the prismatic quill, within [0, 0.2] m by default): four joints alone
    say nothing about the model.

    Parameters
    ----------
    names : sequence of str of length n
        Joint names, in the column order of ``X``.
    X : array_like of shape (N, 3n)
        Samples [q, q', q''] (rad or m, /s, /s²); only q is used.
    params : ScaraParams, optional
        The SCARA; default config/scara.yaml's.
    """
    params = params or ScaraParams()
    x = np.asarray(X, dtype=np.float64)
    if tuple(names) != tuple(params.joint_names) or x.ndim != 2 or x.shape[1] != 3 * _N_JOINTS:
        return False
    low, high = np.asarray(params.position_min), np.asarray(params.position_max)
    margin = LIMIT_MARGIN * (high - low)
    q = x[:, :_N_JOINTS]
    return bool(np.all((q >= low - margin) & (q <= high + margin)))


@dataclass(frozen=True)
class ReferenceFit:
    """A fitted least-squares model; ``seconds``, ``cpu_seconds``: wall and CPU time of the
    fit (s)."""

    identifier: LeastSquaresIdentifier
    seconds: float
    cpu_seconds: float
    n_samples: int


def _split(X: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
    x = np.asarray(X, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3 * _N_JOINTS:
        raise ValueError(f'the SCARA reference needs X of shape (N, {3 * _N_JOINTS}) = '
                         f'[q, qd, qdd] of 4 joints, got {x.shape}')
    return x[:, :_N_JOINTS], x[:, _N_JOINTS:2 * _N_JOINTS], x[:, 2 * _N_JOINTS:]


def fit_reference(X: npt.ArrayLike, Y: npt.ArrayLike, *,
                  coulomb_eps: float | None = None) -> ReferenceFit:
    """Fit the base parameters by least squares.

    Parameters
    ----------
    X : array_like of shape (N, 12)
        [q, q', q''] of the 4 joints (SI).
    Y : array_like of shape (N, 4)
        Efforts (N·m, N).
    coulomb_eps : float, optional
        Velocity scale of the Coulomb smooth sign (rad/s, m/s); default that of
        :class:`ScaraParams`, the simulator's.
    """
    eps = ScaraParams().coulomb_eps if coulomb_eps is None else coulomb_eps
    q, qd, qdd = _split(X)
    wall, cpu = time.perf_counter(), time.process_time()
    identifier = LeastSquaresIdentifier(coulomb_eps=eps).fit(q, qd, qdd, np.asarray(Y, float))
    return ReferenceFit(identifier, time.perf_counter() - wall, time.process_time() - cpu,
                        int(q.shape[0]))


def predict_reference(identifier: LeastSquaresIdentifier, X: npt.ArrayLike) -> FloatArray:
    """Efforts (N, 4) predicted from X (N, 12) = [q, q', q'']."""
    q, qd, qdd = _split(X)
    return np.asarray(identifier.predict(q, qd, qdd), dtype=np.float64).reshape(-1, _N_JOINTS)


def reference_rows(X: npt.ArrayLike, Y: npt.ArrayLike, evaluations: Evaluations | None = None,
                   *, coulomb_eps: float | None = None) -> list[ResultRow]:
    """Offline reference rows: fit on X (N, 12), Y (N, 4) as `fit_reference` does, evaluate
    on ``'train'`` and each evaluation."""
    fit = fit_reference(X, Y, coulomb_eps=coulomb_eps)
    data: dict[str, tuple[npt.ArrayLike, npt.ArrayLike]] = {'train': (X, Y)}
    data.update(evaluations or {})
    return [ResultRow.from_stats(
        effort_errors(y, predict_reference(fit.identifier, x)), table='offline',
        method=REFERENCE, seed=None, data=name, train_time_s=fit.seconds,
        cpu_time_s=fit.cpu_seconds, note='closed-form least squares, 14 base parameters')
        for name, (x, y) in data.items()]


def online_reference_rows(X: npt.ArrayLike, Y: npt.ArrayLike,
                          evaluations: Evaluations | None = None, *,
                          window: int = DEFAULT_WINDOW, paper_window: int = PAPER_WINDOW,
                          coulomb_eps: float | None = None) -> list[ResultRow]:
    """Online-table reference rows, named like those of
    :func:`~scara_ident_ros.paper.table3.online_rows`.

    Fitted on the stream X (N, 12), Y (N, 4) before its last ``max(window, paper_window)``
    samples (at least half of it), evaluated on the last ``paper_window`` and ``window``
    samples and on each evaluation data set.
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    n_fit = max(x.shape[0] - max(window, paper_window), x.shape[0] // 2)
    fit = fit_reference(x[:n_fit], y[:n_fit], coulomb_eps=coulomb_eps)
    predicted = predict_reference(fit.identifier, x)
    extra = dict(iterations=None, train_time_s=fit.seconds, cpu_time_s=fit.cpu_seconds,
                 note=f'least squares fitted on the first {n_fit} stream samples')
    short, long = stream_data_names(window, paper_window)
    rows = [
        ResultRow.from_stats(recent_errors(y, predicted, paper_window), table='online',
                             method=REFERENCE, seed=None, data=short, **extra),
        ResultRow.from_stats(effort_errors(y[-window:], predicted[-window:]), table='online',
                             method=REFERENCE, seed=None, data=long, **extra)]
    for name, (x_eval, y_eval) in (evaluations or {}).items():
        rows.append(ResultRow.from_stats(
            effort_errors(y_eval, predict_reference(fit.identifier, x_eval)), table='online',
            method=REFERENCE, seed=None, data=name, **extra))
    return rows
