"""How an identifier learns a kernel learner's model: its ``partial_fit``, in batches.

Each sample is predicted before it is learnt: with the learner as it is (its running mean
of efforts until it has its first data: :class:`~scara_ident_ros.identification.
streamed_estimator.StreamedEstimator`), then put in a batch; a full batch goes to the
learner's own ``partial_fit``. The first batch is the warm-up (``warmup`` samples: the
learner's standardisation and kernel come from them; a fresh learner is refitted on a
reservoir as the stream grows: :mod:`~scara_ident_ros.identification.learner_stream`), the
others ``batch`` samples. Between refits, with
``batch=1`` each prediction is the learner's own a-priori prediction (``partial_fit``'s),
sample by sample; with more, a sample is predicted by the learner as of the last full batch,
and after N samples the learner is what its ``partial_fit`` of the same batches makes.

:class:`EstimatorLearner` does this in the caller's process (the message path): measured at
0.05-0.1 ms per sample for ``kernel`` (D = 300-500, 7 joints, one BLAS thread), but 30-40 s
once for its kernel's hyperparameters at the end of the warm-up, and for ``gp`` 0.2 ms at
1000 points growing to 5-10 ms at 4000; so the node learns them in a process of its own
(:mod:`~scara_ident_ros.identification.background_estimator`) and this one serves
experiments and tests (reproducible, like ``lm_background: false``).
"""
from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.blas_threads import single_blas_thread
from scara_ident_ros.identification.learner_stream import LearnerStream
from scara_ident_ros.identification.reservoir_lm import RESERVOIR_SIZE
from scara_ident_ros.identification.streamed_estimator import StreamedEstimator, is_fitted

__all__ = ['EstimatorLearner', 'SampleBatch']


class SampleBatch:
    """Samples (x (3n,), y (n,)) gathered until a batch is full.

    Parameters
    ----------
    n_joints : int
        n.
    capacity : int
        Most samples held.
    """

    def __init__(self, n_joints: int, capacity: int) -> None:
        self.n_inputs = 3 * n_joints
        self._rows = np.empty((max(1, capacity), 4 * n_joints))
        self.size = 0

    def add(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> None:
        """Append a sample (the batch must have room)."""
        row = self._rows[self.size]
        row[:self.n_inputs] = x
        row[self.n_inputs:] = y
        self.size += 1

    def take(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The samples as X (N, 3n), Y (N, n) copies; the batch is then empty."""
        rows = self._rows[:self.size].copy()
        self.size = 0
        return rows[:, :self.n_inputs], rows[:, self.n_inputs:]


class EstimatorLearner:
    """Learn a :class:`StreamedEstimator`'s learner in batches, in the caller's process.

    Parameters
    ----------
    model : StreamedEstimator
        The identifier's model.
    batch : int
        Samples per ``partial_fit`` call after the first.
    warmup : int
        Samples of the first call, if the learner has learnt nothing yet.
    reservoir_size : int
        Samples of the reservoir a fresh learner is refitted on
        (:class:`~scara_ident_ros.identification.learner_stream.LearnerStream`).
    seed : int
        The reservoir's seed.

    Attributes
    ----------
    sent : int
        Samples handed to :meth:`learn` (the identifier's learnt samples).
    learnt : int
        Samples the learner's ``partial_fit`` has taken.
    calls : int
        ``partial_fit`` calls.
    seconds : float
        Time spent in them (s).
    dropped : int
        Samples of calls the learner refused (``ValueError``: e.g. too few rows to choose
        its kernel); the learner is as before such a call.
    """

    name = 'estimator'

    def __init__(self, model: StreamedEstimator, *, batch: int, warmup: int,
                 reservoir_size: int = RESERVOIR_SIZE, seed: int = 0) -> None:
        if batch < 1 or warmup < 1:
            raise ValueError(f'need batch >= 1 and warmup >= 1, got {batch} and {warmup}')
        self.model = model
        self.stream = LearnerStream(model.learner, reservoir_size=reservoir_size, warmup=warmup,
                                    seed=seed)
        self.batch_size = int(batch)
        self.warmup = int(warmup)
        self._batch = SampleBatch(model.n_outputs, max(batch, warmup))
        self.sent = 0
        self.learnt = 0
        self.calls = 0
        self.seconds = 0.0
        self.dropped = 0

    def due(self) -> int:
        """Samples the next ``partial_fit`` call takes."""
        return self.batch_size if self.model.fitted else self.warmup

    def learn(self, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
        """Return the prediction of ``y`` (n,) from ``x`` (3n,) made before learning it;
        learn the batch when it is full."""
        self.sent += 1
        model = self.model
        if model.fitted and self.batch_size == 1:  # the learner's own a-priori prediction
            return self._fit(x[np.newaxis], y[np.newaxis])[0]
        predicted = model.predict(x)
        self._batch.add(x, y)
        if not model.fitted:
            model.observe(y)
        if self._batch.size >= self.due():
            self._fit(*self._batch.take())
        return predicted

    def flush(self) -> None:
        """Learn the samples of an unfinished batch now (end of a stream)."""
        if self._batch.size:
            self._fit(*self._batch.take())

    def _fit(self, X: NDArray[np.float64], Y: NDArray[np.float64]) -> NDArray[np.float64]:
        start = time.perf_counter()
        try:
            with single_blas_thread():
                predicted = self.stream.learn(X, Y)
            if self.stream.learner is not self.model.learner:  # refitted
                self.model.replace(self.stream.learner)
            self.model.fitted = self.model.fitted or is_fitted(self.stream.learner)
        except ValueError:
            self.dropped += X.shape[0]
            raise
        finally:
            self.seconds += time.perf_counter() - start
        self.calls += 1
        self.learnt += X.shape[0]
        return predicted
