"""The reference row of a robot without a model here: linear least squares on simple features.

For a recording of any arm (``scara-ident compare --recording``), the SCARA's regressor
(:mod:`~scara_ident_ros.paper.reference`) does not apply. The bar the networks are
measured against is then the effort of each joint fitted, in closed form, as a linear
function of its own features

    [q, q', q'', sin q, cos q, tanh(q' / 0.05), 1]    (all joints' q, q', q'' and the
                                                         trigonometric and friction terms)

(:class:`~scara_ident_ros.learners.linear_features.LinearFeatures`, the linear baseline of
issue 25's TIAGo figures). The rows carry the reference's label
(:data:`~scara_ident_ros.paper.rows.REFERENCE`) and say which fit they are in their note.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from scara_ident_ros.identification import PAPER_WINDOW
from scara_ident_ros.identification.error_window import recent_errors
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.learners.linear_features import (COULOMB_VELOCITY, LinearFeatures,
                                                      linear_features)
from scara_ident_ros.paper.datasets import Evaluations
from scara_ident_ros.paper.rows import REFERENCE, ResultRow
from scara_ident_ros.paper.table3 import DEFAULT_WINDOW, stream_data_names

__all__ = ['COULOMB_VELOCITY', 'LinearFit', 'NOTE', 'fit_linear', 'linear_features',
           'linear_reference_rows', 'online_linear_reference_rows']

NOTE = "linear least squares on [q, q', q'', sin q, cos q, tanh(q'/0.05), 1]"


@dataclass(frozen=True)
class LinearFit:
    """The fitted coefficients (6n + 1, n) and the fit's wall and CPU time (s)."""

    coef: npt.NDArray[np.float64]
    seconds: float
    cpu_seconds: float

    def predict(self, X: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Efforts (N, n) of samples X (N, 3n)."""
        return np.asarray(linear_features(X) @ self.coef, dtype=np.float64)


def fit_linear(X: npt.ArrayLike, Y: npt.ArrayLike) -> LinearFit:
    """Least squares (minimum norm) of Y (N, n) on the features of X (N, 3n)."""
    started, cpu = time.perf_counter(), time.process_time()
    coef = LinearFeatures().fit(X, Y).coef_
    return LinearFit(coef, time.perf_counter() - started, time.process_time() - cpu)


def linear_reference_rows(X: npt.ArrayLike, Y: npt.ArrayLike,
                          evaluations: Evaluations | None = None) -> list[ResultRow]:
    """Offline rows: fitted on X (N, 3n), Y (N, n), evaluated on ``'train'`` and each
    evaluation."""
    fit = fit_linear(X, Y)
    data: dict[str, tuple[npt.ArrayLike, npt.ArrayLike]] = {'train': (X, Y)}
    data.update(evaluations or {})
    return [ResultRow.from_stats(effort_errors(np.asarray(y, float), fit.predict(x)),
                                 table='offline', method=REFERENCE, seed=None, data=name,
                                 train_time_s=fit.seconds, cpu_time_s=fit.cpu_seconds,
                                 note=NOTE)
            for name, (x, y) in data.items()]


def online_linear_reference_rows(X: npt.ArrayLike, Y: npt.ArrayLike,
                                 evaluations: Evaluations | None = None, *,
                                 window: int = DEFAULT_WINDOW,
                                 paper_window: int = PAPER_WINDOW) -> list[ResultRow]:
    """Online rows as :func:`~scara_ident_ros.paper.reference.online_reference_rows` makes
    them: fitted on the stream before its last ``max(window, paper_window)`` samples (at
    least half of it), evaluated on the last ``paper_window`` and ``window`` samples and on
    each evaluation."""
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    n_fit = max(x.shape[0] - max(window, paper_window), x.shape[0] // 2)
    fit = fit_linear(x[:n_fit], y[:n_fit])
    predicted = fit.predict(x)
    extra = dict(iterations=None, train_time_s=fit.seconds, cpu_time_s=fit.cpu_seconds,
                 note=f'{NOTE}, fitted on the first {n_fit} stream samples')
    short, long = stream_data_names(window, paper_window)
    rows = [ResultRow.from_stats(recent_errors(y, predicted, paper_window), table='online',
                                 method=REFERENCE, seed=None, data=short, **extra),
            ResultRow.from_stats(effort_errors(y[-window:], predicted[-window:]),
                                 table='online', method=REFERENCE, seed=None, data=long,
                                 **extra)]
    for name, (x_eval, y_eval) in (evaluations or {}).items():
        rows.append(ResultRow.from_stats(
            effort_errors(np.asarray(y_eval, float), fit.predict(x_eval)), table='online',
            method=REFERENCE, seed=None, data=name, **extra))
    return rows
