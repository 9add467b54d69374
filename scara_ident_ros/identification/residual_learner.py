"""The network side of an online hybrid: residuals of the current θ, checked updates, bounds.

One definition for both places a hybrid's ``lm`` network learns: in the caller's process
(:class:`~scara_ident_ros.identification.hybrid_trainer.HybridTrainer`, synchronous) and in
a learner process beside the stream
(:class:`~scara_ident_ros.identification.background_lm.BackgroundLM`). Why each part is
there: the module docstring of :mod:`~scara_ident_ros.identification.hybrid_trainer`.

Samples (x, τ) are kept with their regressor rows Y(x) in a reservoir, or, in blocks of
:data:`VALIDATION_BLOCK` consecutive samples drawn with probability :data:`VALIDATION_SHARE`,
in a validation reservoir the network never learns. The block is 1 sample: blocks of 100
were tried (neighbours at 1 kHz are nearly equal, so a single held-out sample is partly
learnt through them) and made the online Panda's worst held-out joint worse (6.3e-5 and
6.5e-5 against 4.2e-5 and 4.9e-5 at 120 s, seeds 0 and 1, benchmarks/
learning_curves_panda.md): the gate and the check had fewer distinct states to judge by.
An update
(:meth:`ResidualLearner.step`) fits the network to τ − Y(x) θ with the θ given to it (the
physical model's latest), keeps it only if its validation error (summed over joints) does
not rise, gates the correction per joint (:attr:`HybridModel.gate`, by
:func:`~scara_ident_ros.learners.hybrid_model.gate_scales` as offline: the scale in [0, 1]
the validation samples support, withheld where its gain over :data:`GATE_GROUPS` groups of
them is not significant at :data:`GATE_LEVEL`, so that the hybrid is the physical model
there until an update earns the joint back), and bounds the correction by the range of the
residuals it was fitted to (:attr:`HybridModel.bounds`). The gate was 0 or 1 by the sign of
the validation gain alone: on white noise about the physical model's efforts (nothing to
learn) a correction fitted to the noise passed it by chance, and the frozen hybrid predicted
unseen samples more than 1.5x worse than its physical part on some joint in 6 of 12 runs of
test_background_hybrid.py; the tested, scaled gate at level 0.1 in 1 of 30, at
:data:`GATE_LEVEL` in 0 of 40. The rows are
computed only for samples a reservoir keeps (:meth:`ResidualLearner.add`'s ``rows`` may be a
callable).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.learners.data_region import DataRegion
from scara_ident_ros.learners.hybrid_model import HybridModel, gate_errors, gate_scales
from scara_ident_ros.identification.reservoir import Reservoir
from scara_ident_ros.identification.reservoir_lm import ReservoirLM

__all__ = ['GATE_GROUPS', 'GATE_LEVEL', 'MIN_VALIDATION', 'REGION_POINTS', 'ResidualLearner',
           'Snapshot', 'VALIDATION_BLOCK', 'VALIDATION_SHARE']

FloatArray = NDArray[np.float64]
#: Share of a hybrid's samples kept to check its network's updates.
VALIDATION_SHARE = 0.2
#: Consecutive samples held out (or not) together (1: each drawn alone; module docstring).
VALIDATION_BLOCK = 1
#: Reservoir states the correction's region keeps (it is queried on every sample of the
#: stream: a weight from 500 points in 3n = 18 dimensions took 29 µs, from 2000 48 µs,
#: median of 5 × 2000 calls on a quiet machine).
REGION_POINTS = 500
#: Validation samples needed before the network's first update.
MIN_VALIDATION = 100
#: Groups the validation samples are dealt into (by reservoir slot) for the gate's paired
#: test (:func:`~scara_ident_ros.learners.hybrid_model.gate_scales`): at least
#: :data:`MIN_VALIDATION` / 10 samples each.
GATE_GROUPS = 10
#: The online gate's test level: stricter than offline's
#: (:data:`~scara_ident_ros.learners.hybrid_model.GATE_LEVEL`, one decision on held-out
#: blocks) because online the gate is decided again after every update on the same
#: validation samples, so a correction fitted to noise gets many chances to pass by chance.
GATE_LEVEL = 0.01


@dataclass(frozen=True)
class Snapshot:
    """Copies of what an update uses, taken at once (the reservoirs may change during it).

    ``X`` (m, 3n) and ``stored`` (m, n + n·p): the reservoir's inputs and [τ, Y(x) rows];
    ``X_val``, ``stored_val``: the validation reservoir's; ``theta`` (p,): the physical
    model's parameters the residuals are taken with.
    """

    X: FloatArray
    stored: FloatArray
    X_val: FloatArray
    stored_val: FloatArray
    theta: FloatArray


class ResidualLearner:
    """Learn a :class:`HybridModel`'s network on residuals of the current θ (module docstring).

    Parameters
    ----------
    model : HybridModel
        Its network is learnt in place, its :attr:`~HybridModel.bounds` set; its physical
        part gives the regressor rows of :meth:`add_batch` (θ is given to :meth:`snapshot`).
    network_trainer : ReservoirLM
        Takes the LM steps (:meth:`ReservoirLM.step_on`); its own reservoirs stay empty.
        The reservoir here has their capacity together.
    seed : int
        Seed of the reservoirs' draws.

    Attributes
    ----------
    undone : int
        Updates undone by the validation check.
    """

    def __init__(self, model: HybridModel, network_trainer: ReservoirLM, *,
                 seed: int = 0) -> None:
        self.model, self.network = model, network_trainer
        n, p = model.n_outputs, model.physical.n_parameters
        slow = network_trainer.slow
        capacity = network_trainer.reservoir.capacity + (slow.capacity if slow else 0)
        self._shape = (n, p)
        # the stored columns: τ (n), then the regressor rows Y(x) (n·p)
        self.reservoir = Reservoir(capacity, model.n_inputs, n + n * p, seed=seed)
        self.validation = Reservoir(max(round(capacity * VALIDATION_SHARE), MIN_VALIDATION),
                                    model.n_inputs, n + n * p, seed=seed + 1)
        self._draw = np.random.default_rng(seed + 2)
        self._row = np.empty(n + n * p)
        self._count = 0
        self._held = False
        self.undone = 0

    def add(self, x: FloatArray, y: FloatArray,
            rows: FloatArray | Callable[[], FloatArray]) -> None:
        """Offer a sample x (3n,), τ (n,) with its regressor rows (n, p), or a callable
        giving them: called only if a reservoir keeps the sample."""
        if self._count % VALIDATION_BLOCK == 0:  # a new block: held out or not
            self._held = bool(self._draw.random() < VALIDATION_SHARE)
        self._count += 1
        store = self.validation if self._held else self.reservoir
        slot = store.offer()
        if slot < 0:
            return
        n = self._shape[0]
        row = self._row
        row[:n] = y
        row[n:] = (rows() if callable(rows) else rows).reshape(-1)
        store.put(slot, x, row)

    def add_batch(self, X: FloatArray, Y: FloatArray) -> None:
        """:meth:`add` each sample of X (m, 3n), τ (m, n), its rows from the model's
        physical part."""
        physical, n = self.model.physical, self._shape[0]

        def rows_of(x: FloatArray) -> Callable[[], FloatArray]:
            return lambda: physical.regressor(x[:n], x[n:2 * n], x[2 * n:])

        for x, y in zip(X, Y):
            self.add(x, y, rows_of(x))

    def snapshot(self, theta: FloatArray, *, copy: bool = True) -> Snapshot | None:
        """The reservoirs and ``theta`` for :meth:`step`; None while fewer than
        :data:`MIN_VALIDATION` validation samples are kept. ``copy``: copies (the
        reservoirs may change before the step ends), else views."""
        if len(self.validation) < MIN_VALIDATION:
            return None
        arrays = [self.reservoir.X, self.reservoir.Y, self.validation.X, self.validation.Y]
        if copy:
            arrays = [a.copy() for a in arrays]
        X, stored, X_val, stored_val = arrays
        return Snapshot(X, stored, X_val, stored_val, np.array(theta, dtype=np.float64))

    def step(self, snap: Snapshot | None) -> bool:
        """One checked update of the network on ``snap``'s residuals; return whether its
        weights changed (the bounds are set either way, if ``snap`` is not None)."""
        if snap is None:
            return False
        net = self.model.network
        r_val = self._residual(snap.stored_val, snap.theta)
        scale = np.maximum(snap.stored_val[:, :self._shape[0]].var(axis=0), 1e-300)
        before = net.get_theta()
        residual = self._residual(snap.stored, snap.theta)
        self.model.bounds = (residual.min(axis=0), residual.max(axis=0))
        if snap.X.shape[0] >= 2:  # the correction fades away from the states it learns
            self.model.region = DataRegion.of(snap.X, held_out=snap.X_val,
                                              points=REGION_POINTS)
        correction = self.model.raw_correction(snap.X_val)
        error = gate_errors(correction * self.model.gate, r_val)[1] / scale  # as predicted
        if not self.network.step_on(snap.X, residual):
            self._gate(correction, r_val)
            return False
        correction = self.model.raw_correction(snap.X_val)
        raw = gate_errors(correction, r_val)[1] / scale
        if raw.sum() > error.sum():  # worse over all joints, before gating: undone
            net.set_theta(before)
            self.undone += 1
            return False
        self._gate(correction, r_val)
        return True

    def _gate(self, correction: FloatArray, residual: FloatArray) -> None:
        """Set the model's gate from the validation samples' correction and residual,
        both (m, n), dealt into :data:`GATE_GROUPS` groups by reservoir slot."""
        groups = np.arange(len(residual)) % GATE_GROUPS
        self.model.gate = gate_scales(correction, residual, groups, level=GATE_LEVEL)

    def _residual(self, stored: FloatArray, theta: FloatArray) -> FloatArray:
        """τ − Y(x) θ of stored samples [τ, Y rows]: (m, n)."""
        n, p = self._shape
        return np.asarray(stored[:, :n] - stored[:, n:].reshape(-1, n, p) @ theta)
