"""Table 3 analog: online learning, one back-propagation step per sample of a stream.

Each network starts from its seeded initial weights with the robot-limit scaling (ranges
known before any data arrive, as in the identifier node) and goes through the stream in time
order: for every sample it first predicts the effort (a-priori), then learns from it
(``partial_fit``; the a-priori error is what ``partial_fit`` returns). Evaluated:

``stream-last-<k>``
    the a-priori errors over the stream's last ``k = paper_window`` samples (100: the
    paper's "error over the last 100 samples"), computed by ``ErrorWindow.recent``;
``stream-last-<W>``
    the same over the last ``window`` samples, a steadier figure (W = 5000: 5 s at 1 kHz);
other data sets
    after the stream, predict-only (no learning) on each of ``evaluations``, e.g. a held-out
    run on another excitation.

A stream whose step becomes non-finite stops learning there ("diverged"); its predictions
from then on are NaN, and so are its metrics.

The baseline of `hold_rows` predicts each sample's effort as the previous sample's: no model
at all. At 1 kHz the effort barely changes between samples, so its a-priori error is small;
a network's online error means little unless it beats this.
"""
from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt

from scara_ident_ros.paper.datasets import Evaluations
from scara_ident_ros.paper.hyperparameters import Hyperparameters, Scaling
from scara_ident_ros.identification.error_window import recent_errors
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.rows import HOLD, ResultRow
from scara_ident_ros.identification import PAPER_WINDOW
from scara_ident_ros.nn.presets import METHODS, make_network
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros.nn import FeedForwardNet

__all__ = ['DEFAULT_WINDOW', 'OnlineTrace', 'hold_rows', 'learn_online', 'online_rows',
           'run_online', 'stream_data_names']

FloatArray = npt.NDArray[np.float64]

DEFAULT_WINDOW = 5000  # samples: 5 s at 1 kHz, one period of the 'standard' excitation


@dataclass(frozen=True)
class OnlineTrace:
    """What a network did over a stream.

    Attributes
    ----------
    predicted : ndarray of shape (N, n)
        A-priori predictions (N·m, N); NaN from the divergence on.
    diverged_at : int or None
        First sample of the block in which a step became non-finite.
    seconds, cpu_seconds : float
        Wall and CPU time of the stream (s).
    """

    network: FeedForwardNet
    predicted: FloatArray
    learnt: int
    diverged_at: int | None
    seconds: float
    cpu_seconds: float


def learn_online(network: FeedForwardNet, X: npt.ArrayLike, Y: npt.ArrayLike, *,
                 chunk: int = 1000) -> OnlineTrace:
    """Predict a priori and learn, sample by sample, over a stream.

    Parameters
    ----------
    network : FeedForwardNet
        With its scaling set; trained in place.
    X, Y : array_like of shape (N, 3n), (N, n)
        Inputs and efforts (N·m, N) in time order.
    chunk : int
        Samples per ``partial_fit`` call; a non-finite step marks its whole block diverged
        (the weights stay as before that sample).
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    predicted = np.full(y.shape, np.nan)
    diverged_at = None
    wall, cpu = time.perf_counter(), time.process_time()
    learnt = 0
    with np.errstate(over='ignore', invalid='ignore'):
        for start in range(0, x.shape[0], chunk):
            stop = min(start + chunk, x.shape[0])
            try:
                errors = network.partial_fit(x[start:stop], y[start:stop])
            except ValueError:
                diverged_at = start
                break
            predicted[start:stop] = y[start:stop] - errors
            learnt = stop
    return OnlineTrace(network, predicted, learnt, diverged_at, time.perf_counter() - wall,
                       time.process_time() - cpu)


def stream_data_names(window: int = DEFAULT_WINDOW,
                      paper_window: int = PAPER_WINDOW) -> tuple[str, str]:
    """The ``data`` names of the two stream rows."""
    return f'stream-last-{paper_window}', f'stream-last-{window}'


def online_rows(method: str, seed: int | None, trace: OnlineTrace, Y: npt.ArrayLike,
                evaluations: Evaluations | None = None, *, window: int = DEFAULT_WINDOW,
                paper_window: int = PAPER_WINDOW) -> list[ResultRow]:
    """Rows of one stream (efforts ``Y`` (N, n)): its last ``paper_window`` and ``window``
    samples, then each evaluation data set predicted without learning."""
    y = np.asarray(Y, dtype=np.float64)
    extra = dict(iterations=trace.learnt, train_time_s=trace.seconds,
                 cpu_time_s=trace.cpu_seconds, diverged=trace.diverged_at is not None,
                 note='' if trace.diverged_at is None
                 else f'diverged in the block from sample {trace.diverged_at}')
    short, long = stream_data_names(window, paper_window)
    rows = [
        ResultRow.from_stats(recent_errors(y, trace.predicted, paper_window), table='online',
                             method=method, seed=seed, data=short, **extra),
        ResultRow.from_stats(effort_errors(y[-window:], trace.predicted[-window:]),
                             table='online', method=method, seed=seed, data=long, **extra)]
    for data, (x_eval, y_eval) in (evaluations or {}).items():
        x_eval = np.asarray(x_eval, dtype=np.float64)
        y_eval = np.asarray(y_eval, dtype=np.float64)
        if trace.diverged_at is None:
            predicted = trace.network.predict(x_eval)
        else:
            predicted = np.full(y_eval.shape, np.nan)
        rows.append(ResultRow.from_stats(effort_errors(y_eval, predicted), table='online',
                                         method=method, seed=seed, data=data, **extra))
    return rows


def run_online(X: npt.ArrayLike, Y: npt.ArrayLike, evaluations: Evaluations | None = None, *,
               scaling: Scaling, methods: Sequence[str] = tuple(METHODS),
               seeds: Iterable[int] = range(5),
               hyperparameters: Mapping[str, Hyperparameters] | None = None,
               window: int = DEFAULT_WINDOW, paper_window: int = PAPER_WINDOW,
               progress: Callable[[str], None] | None = None) -> list[ResultRow]:
    """Every method from every seed learns the stream: the rows of the Table 3 analog.

    Parameters
    ----------
    X, Y : array_like of shape (N, 3n), (N, n)
        The stream's inputs (q'' estimated, as online) and efforts, in time order.
    scaling : (x_min, x_max, y_min, y_max)
        Physical ranges mapped to [-1, 1] (the robot limits).
    methods, seeds, hyperparameters, progress
        As in :func:`scara_ident_ros.paper.table2.train_offline`.
    """
    x = np.asarray(X, dtype=np.float64)
    y = np.asarray(Y, dtype=np.float64)
    seeds = list(seeds)
    rows: list[ResultRow] = []
    for name in methods:
        label = method_spec(name).label
        hyper = (hyperparameters or {}).get(name) or Hyperparameters.defaults(name)
        for seed in seeds:
            net = make_network(name, y.shape[1], seed=seed, **asdict(hyper))
            net.set_scaling(*scaling)
            trace = learn_online(net, x, y)
            new = online_rows(label, seed, trace, y, evaluations, window=window,
                              paper_window=paper_window)
            rows.extend(new)
            if progress is not None:
                progress(f'online {label} seed {seed}: {trace.learnt} samples in '
                         f'{trace.seconds:.1f} s, last-{paper_window} MSE '
                         f'{new[0].mse_mean:.3g}, {new[-1].data} NMSE {new[-1].nmse_mean:.3g}')
    return rows


def hold_rows(Y: npt.ArrayLike, *, window: int = DEFAULT_WINDOW,
              paper_window: int = PAPER_WINDOW) -> list[ResultRow]:
    """Stream rows (as in `online_rows`) of the baseline that predicts the previous
    sample's effort, for efforts ``Y`` (N, n) in time order."""
    y = np.asarray(Y, dtype=np.float64)
    predicted = np.full(y.shape, np.nan)
    predicted[1:] = y[:-1]
    short, long = stream_data_names(window, paper_window)
    note = 'baseline: each effort predicted as the previous sample\'s'
    return [ResultRow.from_stats(recent_errors(y, predicted, paper_window), table='online',
                                 method=HOLD, seed=None, data=short, note=note),
            ResultRow.from_stats(effort_errors(y[-window:], predicted[-window:]),
                                 table='online', method=HOLD, seed=None, data=long,
                                 note=note)]
