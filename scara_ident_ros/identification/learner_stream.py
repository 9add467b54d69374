"""A kernel learner on a stream: its ``partial_fit``, and refits on a reservoir of the stream.

A kernel learner standardises its inputs and efforts, and sets its kernel, with its first
data. On a stream those are the first ``warmup`` samples, whose motion may span a small part
of what follows (TIAGo's first 10 s move its joints by 1-8 % of their later spread): later
inputs then lie tens of standard deviations out, where the kernel knows nothing. So a fresh
learner is refitted, when it has learnt 2, 4, 8, ... times ``warmup`` samples, from scratch
(``type(learner)(**learner.get_params()).fit``) on a uniform reservoir of every sample it has
learnt (in stream order), and goes on with ``partial_fit`` from there: log₂ refits in all. A
warm start (a learner fitted before, e.g. offline on a whole recording) is not refitted, nor
is a learner whose ``partial_fit`` holds its batch solution on every sample learnt (a class
attribute ``exact_online`` True: the linear model, which chooses nothing from its first data;
a refit on the reservoir would only lose samples).
"""
from __future__ import annotations

from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.identification.streamed_estimator import ArrayLearner, is_fitted

__all__ = ['LearnerStream']


class LearnerStream:
    """Learn a stream's samples with a learner's ``partial_fit``; refit it as it grows.

    Parameters
    ----------
    learner : ArrayLearner
        Fresh (refitted as the module docstring says) or fitted (never refitted).
    reservoir_size : int
        Samples the reservoir keeps (the node's ``reservoir_size``).
    warmup : int
        Samples of the learner's first call; refits at 2, 4, 8, ... times this many.
    seed : int
        Seed of the reservoir's draws.

    Attributes
    ----------
    learner : ArrayLearner
        The learner of the moment (a refit makes a new one).
    learnt : int
        Samples learnt.
    refits : int
        Refits done.
    """

    def __init__(self, learner: ArrayLearner, *, reservoir_size: int, warmup: int,
                 seed: int = 0) -> None:
        self.learner = learner
        self.learnt = 0
        self.refits = 0
        self._reservoir_size, self._seed = int(reservoir_size), int(seed)
        refits = not is_fitted(learner) and not getattr(learner, 'exact_online', False)
        self._next = 2 * int(warmup) if refits else None
        self._reservoir: Reservoir | None = None

    def learn(self, X: NDArray[np.float64], Y: NDArray[np.float64]) -> NDArray[np.float64]:
        """``partial_fit`` the samples X (N, 3n), Y (N, n) in order; refit when due.
        Returns the learner's predictions (N, n) made before learning each."""
        predicted = np.asarray(self.learner.partial_fit(X, Y), dtype=np.float64)
        if self._next is not None:
            if self._reservoir is None:
                self._reservoir = Reservoir(self._reservoir_size, X.shape[1] + 1, Y.shape[1],
                                            seed=self._seed)
            for i in range(X.shape[0]):
                slot = self._reservoir.offer()
                if slot >= 0:
                    self._reservoir.put(slot, np.r_[self.learnt + i, X[i]], Y[i])
        self.learnt += X.shape[0]
        if self._next is not None and self.learnt >= self._next:
            self._refit()
            self._next *= 2
        return predicted

    def _refit(self) -> None:
        """A fresh learner of the same hyperparameters, fitted on the reservoir in stream
        order."""
        reservoir = self._reservoir
        assert reservoir is not None
        order = np.argsort(reservoir.X[:, 0], kind='stable')
        X, Y = reservoir.X[order, 1:], reservoir.Y[order]
        fresh = cast(Any, type(self.learner))(**self.learner.get_params())
        fresh.fit(X, Y)
        fresh.metadata = self.learner.metadata
        self.learner = cast(ArrayLearner, fresh)
        self.refits += 1
