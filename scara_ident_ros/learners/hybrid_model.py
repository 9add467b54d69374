"""The hybrid model: a physical model plus a network fitted to what it leaves unexplained.

    τ̂(x) = Y(q, q', q'') θ + N(x),    x = [q, q', q'']

The physical part (:class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel`) carries
what the rigid-body structure and the friction law explain; the network N (an FFS network
by default) learns the residual τ − Y θ: unmodelled effects, a Coulomb shape other than the
law's, the q'' estimate's lag. Without the robot's URDF the part linear in its parameters
can be least squares on simple features instead
(:class:`~scara_ident_ros.learners.linear_features.LinearFeatures`, ``scara-ident train
--method linear_hybrid``): the same fit, gate and file, offline only (the online hybrid
learns a physical part by RLS). Offline (:func:`fit_hybrid`): least squares first, on every
training sample, then the network on the residual with Levenberg–Marquardt. The network's
output scaling is the residual's range on the training samples, not the effort limits (the
residual is a small fraction of them: scaled by the limits, its targets would crowd near 0).

A network fitted to a small residual overfits easily: trained without a stop rule, a
hybrid predicts a wrist's held-out motion far worse than the physical model alone
(benchmarks/physical.md). :func:`fit_hybrid` therefore early-stops on the validation
samples' residual and keeps the network of the best validation error. The network starts
with zero output weights and the output bias of a zero residual (:func:`start_at_zero`):
the hybrid starts as the physical model alone, so when no iteration improves the
validation error (``history.best_iteration == 0``) the hybrid is the physical model, not
the physical model plus a random network.

The network's correction can be bounded per joint (:attr:`HybridModel.bounds`): online, the
range of the residuals it was fitted to. A network extrapolates badly outside the states it
has seen; bounded, its error on a motion never seen is at most the residual's own range,
so the hybrid cannot do much worse there than the physical model alone.

And the correction is *gated* per joint (:attr:`HybridModel.gate`, a scale in [0, 1]):
validated on samples neither part learnt from (:meth:`HybridModel.validate_gate`,
:func:`gate_scales`), it is scaled by the least-squares factor those samples support
(clipped to [0, 1]: a correction that is partly noise is shrunk), and withheld (gate 0) on
each joint where its gain is not shown: the gain is measured block by block, each block
with the scale fitted on the others, and its mean over the blocks must exceed
t(1 − :data:`GATE_LEVEL`, B − 1) standard errors (a one-sided paired t-test over the B
blocks). On a real arm a residual network that helps on the
training motion can make another motion worse on some joints, and a few validation blocks
can all agree by chance: on the TX40, a gate that kept a correction lowering the error in
each of 3 validation blocks left the hybrid worse than its physical part on held-out blocks
in 1 of 25 (split, seed) pairs (joint 4, 1.7×), this one in none; a positive mean gain
(level 0.5) in 6. On the simulated SCARA and UR5 the scale lowers the worst held-out joint
below the all-or-nothing gate's (benchmarks/physical_real.md).
Offline :func:`fit_hybrid` gates on held-out samples, block by block (``scara-ident
train``: its network early-stops on every other validation block and the gate uses all
of them); online the residual learner gates the same way after every update, on its own
held-out samples (:mod:`~scara_ident_ros.identification.residual_learner`).

And the correction fades where the input leaves the states it was learnt on
(:attr:`HybridModel.region`, :class:`~scara_ident_ros.learners.data_region.DataRegion`: 1
near the network's training inputs, 0 beyond three times the distance of held-out states),
so that on motion it has not seen the hybrid returns to its physical part instead of extrapolating
(:func:`fit_hybrid` sets it; online the residual learner sets it to its reservoir's inputs
after every update).

The hybrid keeps the estimator contract (:mod:`scara_ident_ros.estimator`): :meth:`HybridModel.fit`
is :func:`fit_hybrid` with the project's defaults of offline training.

Files: kind ``'hybrid'`` (:mod:`scara_ident_ros.nn.model_file`): the physical part's entries
prefixed ``physical.`` (its kind in ``base_kind``: ``physical`` if absent, older files), the
network's ``network.``, the bounds (if any) ``residual_low``
and ``residual_high``, the gate ``residual_gate`` (in [0, 1]; all 1 if absent: older
files), the data region (if any) ``region.``-prefixed (none in older files: no fade).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import stdtrit

from scara_ident_ros.dynamics.physical_model import PhysicalModel
from scara_ident_ros.estimator import Estimator, SavedEstimator, register_kind
from scara_ident_ros.learners.data_region import DataRegion
from scara_ident_ros.learners.linear_features import LinearFeatures
from scara_ident_ros.nn import FeedForwardNet, FitHistory, ModelFormatError, fit
from scara_ident_ros.nn.fitting import ITERATIONS, MAX_FAIL, MIN_ITERATIONS, SAMPLES
from scara_ident_ros.nn.validation_blocks import VALIDATION_FRACTION, row_split
from scara_ident_ros.nn.presets import HIDDEN_UNITS, make_network
from scara_ident_ros.nn.model_file import NETWORK_PREFIX
from scara_ident_ros.nn.training import Callback

__all__ = ['GATE_CHUNKS', 'GATE_LEVEL', 'HybridModel', 'KIND', 'RESIDUAL_SHARE',
           'fit_hybrid', 'gate_errors', 'gate_scales', 'online_hybrid', 'start_at_zero']

FloatArray = NDArray[np.float64]
KIND = 'hybrid'  #: the model file's kind
#: An online hybrid's network outputs span this share of the effort limits (a residual is
#: a fraction of the effort; online its range is not known in advance).
RESIDUAL_SHARE = 0.25
_PHYSICAL_PREFIX = 'physical.'
_REGION_PREFIX = 'region.'
#: Level of the gate's one-sided paired t-test: a correction is kept on a joint if its mean
#: held-out gain over B blocks exceeds t(1 − level, B − 1) standard errors
#: (:func:`gate_scales`; benchmarks/physical_real.md).
GATE_LEVEL = 0.1
#: Runs of consecutive rows a gate cuts held-out samples without blocks into.
GATE_CHUNKS = 5


class LinearPart(Estimator, Protocol):
    """The part of a hybrid linear in its parameters, τ = Y(x) θ, that the network corrects:
    a :class:`PhysicalModel` (from a URDF) or :class:`LinearFeatures` (none)."""

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The entries its ``from_arrays`` rebuilds it from."""


#: How a file's physical part is rebuilt, by its kind (``base_kind``)
_LINEAR_PARTS: dict[str, Callable[..., LinearPart]] = {
    PhysicalModel.kind: PhysicalModel.from_arrays,
    LinearFeatures.kind: LinearFeatures.from_arrays}


class HybridModel(SavedEstimator):
    """Physical model plus a residual network; predicts like a network.

    Parameters
    ----------
    physical : PhysicalModel or LinearFeatures
        The fitted part linear in its parameters (:class:`LinearPart`): the robot's
        physical model or, without its URDF, least squares on simple features.
    network : FeedForwardNet
        A 3n-H-n network of the residual, in the same joint order.

    Attributes
    ----------
    base : PhysicalModel or LinearFeatures
        The ``physical`` argument; :attr:`physical` hands it out typed as a physical model.
    metadata : dict of str to ndarray
        Saved with the model (``joint_names``, ``method``, ...).
    bounds : (low, high) of ndarrays of shape (n,), or None
        The network's correction is clipped to [low, high] per joint (N·m, N); None: not
        bounded.
    gate : ndarray of shape (n,)
        The correction's scale per joint, in [0, 1]: 0 where it is withheld
        (:meth:`validate_gate`); all 1 until validated.
    region : DataRegion or None
        The inputs the network was fitted to: its correction is weighted by
        :meth:`DataRegion.weight` (0 far from them); None: not weighted.
    history_ : FitHistory or None
        The network's training in the last :meth:`fit`.
    """

    #: The model file's kind (:func:`scara_ident_ros.estimator.load_model`).
    kind = KIND

    def __init__(self, physical: LinearPart, network: FeedForwardNet) -> None:
        if (network.n_inputs, network.n_outputs) != (physical.n_inputs, physical.n_outputs):
            raise ValueError(f'a {network.n_inputs}-{network.n_outputs} network cannot correct '
                             f'a {physical.kind} model of {physical.n_outputs} joints')
        self.base, self.network = physical, network
        self.bounds: tuple[FloatArray, FloatArray] | None = None
        self.gate: FloatArray = np.ones(physical.n_outputs)
        self.region: DataRegion | None = None
        names = physical.joint_names
        self.metadata: dict[str, np.ndarray] = (
            {} if names is None else {'joint_names': np.array(names)})
        self.history_: FitHistory | None = None

    @property
    def physical(self) -> PhysicalModel:
        """The physical part as the robot's physical model (what the online hybrid learns
        and ``export --urdf`` writes).

        Raises
        ------
        TypeError
            If it is least squares on simple features (:attr:`base`'s kind ``linear``).
        """
        if self.base.kind != PhysicalModel.kind:
            raise TypeError(f'this hybrid\'s linear part is a {self.base.kind} model, not a '
                            'physical model of a URDF')
        return cast(PhysicalModel, self.base)

    @property
    def n_inputs(self) -> int:
        """3n."""
        return self.base.n_inputs

    @property
    def n_outputs(self) -> int:
        """n."""
        return self.base.n_outputs

    @property
    def joint_names(self) -> tuple[str, ...] | None:
        """The joints, in input and output order: the physical part's, else those recorded in
        :attr:`metadata` (None if neither has them)."""
        names = self.base.joint_names
        recorded = self.metadata.get('joint_names')
        if names is None and recorded is not None:
            names = tuple(str(name) for name in np.atleast_1d(recorded))
        return names

    def get_params(self) -> dict[str, Any]:
        """The hyperparameters of both parts, as data: ``{'physical': {...},
        'network': {...}}``."""
        return {'physical': self.base.get_params(), 'network': self.network.get_params()}

    def fit(self, X: ArrayLike, Y: ArrayLike, *,
            validation: tuple[ArrayLike, ArrayLike] | None = None,
            validation_fraction: float = VALIDATION_FRACTION,
            gate_validation: tuple[ArrayLike, ArrayLike] | None = None,
            gate_groups: ArrayLike | None = None,
            x_range: tuple[ArrayLike, ArrayLike] | None = None,
            samples: int = SAMPLES, iterations: int = ITERATIONS, max_fail: int = MAX_FAIL,
            min_iterations: int = MIN_ITERATIONS, region_inputs: ArrayLike | None = None,
            callback: Callback | None = None) -> HybridModel:
        """Least squares, then the network on the residual (:func:`fit_hybrid`), in place.

        Parameters
        ----------
        X : array_like of shape (N, 3n)
            [q, q', q''], rows in time order.
        Y : array_like of shape (N, n)
            Efforts (N·m, N).
        validation : (X, Y), optional
            Validation samples; if None, blocks of consecutive rows (a
            ``validation_fraction`` of them, spread over the rows, drawn with the network's
            seed: ``nn.validation_blocks.row_split``) validate and the others train.
        gate_validation, gate_groups, x_range, iterations, max_fail, min_iterations
            :func:`fit_hybrid`'s.
        region_inputs, callback
            :func:`fit_hybrid`'s.
        samples : int
            The network trains on at most this many training samples (0: all).

        Returns
        -------
        HybridModel
            ``self``, the network's training in :attr:`history_`.
        """
        x = np.asarray(X, dtype=np.float64)
        y = np.asarray(Y, dtype=np.float64)
        seed = self.network.seed
        if validation is None and x.ndim == 2 and x.shape[0] == y.shape[0]:
            train, held = row_split(x.shape[0], validation_fraction, seed=seed)
            if held.shape[0]:
                validation = (x[held], y[held])
                x, y = x[train], y[train]
        fitted, history = fit_hybrid(
            self.base, self.network, (x, y), validation=validation,
            gate_validation=gate_validation, gate_groups=gate_groups, x_range=x_range,
            network_samples=samples, seed=seed, iterations=iterations, max_fail=max_fail,
            min_iterations=min_iterations, region_inputs=region_inputs, callback=callback)
        # the fitted hybrid's state (its parts are this one's; bounds and the like), this
        # one's metadata kept
        state = {key: value for key, value in vars(fitted).items() if key != 'metadata'}
        vars(self).update(state, history_=history)
        return self

    def predict(self, X: ArrayLike) -> FloatArray:
        """Efforts of X (N, 3n) = [q, q', q''] (or (3n,)): physical plus network, (N, n)."""
        x = np.asarray(X, dtype=np.float64)
        return self.base.predict(x) + self.correction(x)

    def correction(self, X: ArrayLike) -> FloatArray:
        """The network's part of :meth:`predict`, within :attr:`bounds`, times :attr:`gate`:
        (N, n) or (n,). With every joint gated off it is 0 without asking the network or the
        region (the online hybrid calls this on every sample)."""
        if not np.any(self.gate):
            x = np.asarray(X, dtype=np.float64)
            return np.zeros(x.shape[:-1] + (self.n_outputs,))
        return self.raw_correction(X) * self.gate

    def raw_correction(self, X: ArrayLike) -> FloatArray:
        """The network's correction within :attr:`bounds`, weighted by :attr:`region`, not
        gated: (N, n) or (n,)."""
        x = np.asarray(X, dtype=np.float64)
        out = self.network.predict(x)
        if self.bounds is not None:
            out = np.clip(out, self.bounds[0], self.bounds[1])
        if self.region is not None:
            out = out * self.region.weight(x)[..., None]
        return out

    def validate_gate(self, X: ArrayLike, Y: ArrayLike, *, groups: ArrayLike | None = None,
                      level: float = GATE_LEVEL) -> tuple[FloatArray, FloatArray]:
        """Set :attr:`gate` on held-out samples: per joint the scale in [0, 1] of the
        correction that the samples support (:func:`gate_scales`), 0 where its cross-validated
        gain is not significantly positive.

        Parameters
        ----------
        X : array_like of shape (N, 3n)
            Held-out inputs [q, q', q''] that neither part was fitted to, in time order.
        Y : array_like of shape (N, n)
            Their efforts (N·m, N).
        groups : array_like of shape (N,), optional
            A label per sample: its time block. Without, the rows are cut into
            :data:`GATE_CHUNKS` runs of consecutive rows.
        level : float
            :func:`gate_scales`'s.

        Returns
        -------
        physical, corrected : ndarray of shape (n,)
            Mean squared error per joint of the physical model alone and with the
            (ungated, unscaled) correction (N²·m², N²).

        Raises
        ------
        ValueError
            Without samples, or if the shapes do not fit the model.
        """
        x = np.atleast_2d(np.asarray(X, dtype=np.float64))
        y = np.atleast_2d(np.asarray(Y, dtype=np.float64))
        if x.shape[0] == 0 or x.shape != (y.shape[0], self.n_inputs) \
                or y.shape[1] != self.n_outputs:
            raise ValueError(f'need held-out X (N, {self.n_inputs}) and Y (N, '
                             f'{self.n_outputs}), N > 0; got {x.shape} and {y.shape}')
        residual = y - self.base.predict(x)
        correction = self.raw_correction(x)
        self.gate = gate_scales(correction, residual, groups, level=level)
        return gate_errors(correction, residual)

    def partial_fit(self, X: FloatArray, Y: FloatArray) -> FloatArray:
        """Not learnt online yet.

        Raises
        ------
        NotImplementedError
            Always: offline only (:meth:`fit`), or online through the identifier's
            ``HybridTrainer``.
        """
        raise NotImplementedError('a HybridModel is fitted offline (fit)')

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Both parts, the bounds, the gate and the region as the file's entries (module
        docstring), without the metadata."""
        arrays = {_PHYSICAL_PREFIX + k: v for k, v in self.base.to_arrays().items()}
        arrays['base_kind'] = np.array(self.base.kind)
        arrays.update({NETWORK_PREFIX + k: v for k, v in self.network.to_arrays().items()})
        if self.bounds is not None:
            arrays['residual_low'], arrays['residual_high'] = self.bounds
        arrays['residual_gate'] = self.gate.copy()
        if self.region is not None:
            arrays.update({_REGION_PREFIX + k: v for k, v in self.region.to_arrays().items()})
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], *, source: str) -> HybridModel:
        """Rebuild from :meth:`to_arrays`'s entries; ``source`` names them in errors.

        Raises
        ------
        ModelFormatError
            If they are not a hybrid model of ours or are corrupt.
        """
        base_kind = str(arrays.get('base_kind', PhysicalModel.kind))
        if base_kind not in _LINEAR_PARTS:
            raise ModelFormatError(f'{source}: a hybrid whose linear part is of unknown kind '
                                   f'{base_kind!r} (known: {", ".join(_LINEAR_PARTS)})')

        def part(prefix: str) -> dict[str, np.ndarray]:
            return {k[len(prefix):]: v for k, v in arrays.items() if k.startswith(prefix)}

        physical = _LINEAR_PARTS[base_kind](part(_PHYSICAL_PREFIX), source=source)
        network = FeedForwardNet.from_arrays(part(NETWORK_PREFIX))
        try:
            model = cls(physical, network)
            if 'residual_low' in arrays:
                low = np.asarray(arrays['residual_low'], np.float64)
                high = np.asarray(arrays['residual_high'], np.float64)
                if low.shape != (model.n_outputs,) or high.shape != low.shape:
                    raise ValueError(f'bounds of shape {low.shape}, {high.shape}')
                model.bounds = (low, high)
            if 'residual_gate' in arrays:
                gate = np.asarray(arrays['residual_gate'], np.float64)
                if gate.shape != (model.n_outputs,) or not np.all((gate >= 0) & (gate <= 1)):
                    raise ValueError(f'a gate of shape {gate.shape} not in [0, 1]')
                model.gate = gate
            region = part(_REGION_PREFIX)
            if region:
                model.region = DataRegion.from_arrays(region)
                if model.region.reference.shape[1] != model.n_inputs:
                    raise ValueError(f'a data region of {model.region.reference.shape[1]} '
                                     f'inputs, not {model.n_inputs}')
        except (KeyError, ValueError) as exc:
            raise ModelFormatError(f'{source}: corrupt hybrid model: {exc}') from None
        return model


def gate_errors(correction: FloatArray,
                residual: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Mean squared error per joint of no correction and of ``correction`` (N, n) on the
    physical model's ``residual`` (N, n): the two errors a gate compares, (n,) each."""
    return (np.asarray(np.mean(residual ** 2, axis=0)),
            np.asarray(np.mean((correction - residual) ** 2, axis=0)))


register_kind(KIND, HybridModel.load)


def gate_scales(correction: ArrayLike, residual: ArrayLike,
                groups: ArrayLike | None = None, *,
                level: float = GATE_LEVEL) -> FloatArray:
    """The gate per joint: the scale in [0, 1] of ``correction`` that held-out samples
    support, 0 where its gain is not significantly positive.

    The scale s is least squares on all samples, clipped to [0, 1]: s = <r, c> / <c, c>
    (shrinking a correction that is partly noise). Whether it helps is judged on held-out
    blocks as the held-out data will be: for each block b the scale is refitted on the
    other blocks (s₋b) and the block's gain is its mean squared error without correction
    minus with s₋b times it. The correction is kept on a joint only if the mean gain over
    the B blocks exceeds t(1 − ``level``, B − 1) standard errors of that mean: a one-sided
    paired t-test over blocks at that level (blocks, not samples: a few blocks of a real
    arm's motion differ more than their samples do, and neighbouring samples are nearly
    equal). With a single block there is no test: s.

    Parameters
    ----------
    correction : array_like of shape (N, n)
        The residual model's (ungated) correction on held-out samples (N·m, N).
    residual : array_like of shape (N, n)
        The physical model's residual τ − Y θ there.
    groups : array_like of shape (N,), optional
        Each sample's block (e.g. its time block); default :data:`GATE_CHUNKS` runs of
        consecutive rows (rows in time order).
    level : float
        The test's level, in (0, 1) (0.5: a positive mean gain is enough).

    Returns
    -------
    ndarray of shape (n,)
        The gate, in [0, 1].

    Raises
    ------
    ValueError
        If the shapes differ, there are no samples or the level is outside (0, 1).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f'the gate\'s test level must be in (0, 1), got {level}')
    c = np.atleast_2d(np.asarray(correction, dtype=np.float64))
    r = np.atleast_2d(np.asarray(residual, dtype=np.float64))
    if c.shape != r.shape or c.shape[0] == 0:
        raise ValueError(f'need a correction and a residual of one shape (N, n), N > 0; '
                         f'got {c.shape} and {r.shape}')
    n_rows = c.shape[0]
    if groups is None:
        labels = np.arange(n_rows) * min(GATE_CHUNKS, n_rows) // n_rows
    else:
        labels = np.asarray(groups).reshape(-1)
        if labels.shape != (n_rows,):
            raise ValueError(f'need a group per sample ({n_rows}), got {labels.shape}')
    _, block = np.unique(labels, return_inverse=True)
    n_blocks = int(block.max()) + 1
    rc = np.zeros((n_blocks, c.shape[1]))
    cc = np.zeros_like(rc)
    np.add.at(rc, block, r * c)
    np.add.at(cc, block, c * c)
    counts = np.bincount(block, minlength=n_blocks)[:, None].astype(np.float64)

    def scale(num: FloatArray, den: FloatArray) -> FloatArray:
        ratio = np.divide(num, den, out=np.zeros_like(num), where=den > 0.0)
        return np.asarray(np.clip(ratio, 0.0, 1.0))

    every = scale(rc.sum(axis=0), cc.sum(axis=0))
    if n_blocks == 1:
        return every
    others = scale(rc.sum(axis=0) - rc, cc.sum(axis=0) - cc)  # (B, n): s₋b
    gain = (2.0 * others * rc - others ** 2 * cc) / counts  # MSE without minus with
    mean = gain.mean(axis=0)
    error = gain.std(axis=0, ddof=1) / np.sqrt(n_blocks)
    margin = float(stdtrit(n_blocks - 1, 1.0 - level))  # Student t quantile
    keep = (mean > 0.0) & (mean > margin * error)
    return np.where(keep, every, 0.0)


def start_at_zero(network: FeedForwardNet) -> None:
    """Make ``network`` (scaling set) predict 0 everywhere: output weights 0, the output
    bias the scaled value of 0. Its hidden units keep their initial weights; Levenberg–
    Marquardt's first step fits the output layer on them, later steps move them too."""
    theta = network.get_theta()
    _, output = network.unpack(theta)
    output[:, :-1] = 0.0
    output[:, -1] = network.y_scaling.transform(np.zeros(network.n_outputs))
    network.set_theta(theta)


def online_hybrid(physical: PhysicalModel,
                  scaling: Sequence[ArrayLike], *,
                  n_hidden: int = HIDDEN_UNITS, seed: int = 0, friction_steps: bool = True,
                  share: float = RESIDUAL_SHARE) -> HybridModel:
    """A hybrid to learn online: ``physical`` from the URDF's inertias, an FFS residual
    network at zero output.

    Parameters
    ----------
    physical : PhysicalModel
        Its θ is set to the URDF's own (:meth:`PhysicalModel.urdf_parameters`, RLS's
        prior mean).
    scaling : (x_min, x_max, y_min, y_max)
        The robot's limit scaling (``methods.limit_scaling``): inputs (3n,), efforts (n,).
    n_hidden, seed, friction_steps
        The FFS network's hidden units, weight seed and friction-step units.
    share : float
        The network's outputs span ``share`` of the effort scaling.
    """
    physical.set_theta(physical.urdf_parameters())
    network = make_network('ffs', physical.n_joints, n_hidden=n_hidden, seed=seed,
                           friction_steps=friction_steps)
    x_min, x_max, y_min, y_max = scaling
    network.set_scaling(x_min, x_max, share * np.asarray(y_min, float),
                        share * np.asarray(y_max, float))
    start_at_zero(network)
    return HybridModel(physical, network)


def fit_hybrid(physical: LinearPart, network: FeedForwardNet,
               train: tuple[ArrayLike, ArrayLike], *,
               validation: tuple[ArrayLike, ArrayLike] | None = None,
               gate_validation: tuple[ArrayLike, ArrayLike] | None = None,
               gate_groups: ArrayLike | None = None,
               x_range: tuple[ArrayLike, ArrayLike] | None = None,
               network_samples: int = 0, seed: int = 0, iterations: int = ITERATIONS,
               max_fail: int = MAX_FAIL, min_iterations: int = MIN_ITERATIONS,
               fade: bool = True, region_inputs: ArrayLike | None = None,
               callback: Callback | None = None) -> tuple[HybridModel, FitHistory]:
    """Least squares, then the network on the residual, early-stopped on validation.

    Parameters
    ----------
    physical : PhysicalModel or LinearFeatures
        The part linear in its parameters (:class:`LinearPart`), fitted here on every
        training sample.
    network : FeedForwardNet
        Fresh 3n-H-n network (e.g. ``make_network('ffs', n)``); its scaling is set here.
    train : (X, Y)
        Training inputs (N, 3n) = [q, q', q''] and efforts (N, n).
    validation : (X, Y), optional
        Validation samples, rows in time order: the network stops after ``max_fail``
        iterations without a new best residual error on them (counted after
        ``min_iterations``) and keeps its best; then its correction is gated per joint
        (:meth:`HybridModel.validate_gate`) on ``gate_validation``, or on them without it.
    gate_validation : (X, Y), optional
        Held-out samples to gate on (default ``validation``).
    gate_groups : array_like of shape (N,), optional
        Their time blocks (:meth:`HybridModel.validate_gate`'s ``groups``; default runs of
        consecutive rows).
    x_range : (x_min, x_max) of shape (3n,), optional
        The network's input ranges (e.g. from the robot's limits); default the training
        inputs' range.
    network_samples : int
        Train the network on at most this many training samples drawn with ``seed``
        (0: all).
    seed : int
        Seed of that draw.
    iterations, max_fail, min_iterations : int
        Levenberg–Marquardt's limits (``nn.fit``).
    fade : bool
        Weight the correction by the region of the training inputs
        (:attr:`HybridModel.region`), so that the gate judges the correction as it is
        applied (early stopping judges the network's own output).
    region_inputs : array_like of shape (M, 3n), optional
        Held-out inputs inside the region learnt on, whose distances to the training inputs
        set the region's radius (:meth:`DataRegion.of`): samples interleaved with the
        training motion, not later motion (there the correction should fade). Default the
        validation inputs.
    callback : callable, optional
        ``nn.fit``'s progress callback.

    Returns
    -------
    model : HybridModel
    history : FitHistory
        The network's training.
    """
    x = np.asarray(train[0], dtype=np.float64)
    y = np.asarray(train[1], dtype=np.float64)
    physical.fit(x, y)
    x_all = x
    if network_samples and network_samples < x.shape[0]:
        rows = np.sort(np.random.default_rng(seed).choice(x.shape[0], network_samples,
                                                          replace=False))
        x, y = x[rows], y[rows]
    residual = y - physical.predict(x)
    x_min, x_max = ((x.min(axis=0), x.max(axis=0)) if x_range is None else
                    (np.asarray(x_range[0], float), np.asarray(x_range[1], float)))
    network.set_scaling(x_min, x_max, residual.min(axis=0), residual.max(axis=0))
    start_at_zero(network)
    val = held = None
    if validation is not None:
        xv = np.asarray(validation[0], dtype=np.float64)
        if xv.shape[0]:
            held = (xv, np.asarray(validation[1], dtype=np.float64))
            val = (xv, held[1] - physical.predict(xv))
    history = fit(network, x, residual, algorithm='lm', iterations=iterations,
                  validation=val, max_fail=max_fail, min_iterations=min_iterations,
                  callback=callback)
    model = HybridModel(physical, network)
    if fade and x_all.shape[0] >= 2:
        inside = region_inputs if region_inputs is not None else (
            None if val is None else val[0])
        model.region = DataRegion.of(x_all, held_out=inside, seed=seed)
    if gate_validation is not None and np.asarray(gate_validation[0]).shape[0]:
        held = (np.asarray(gate_validation[0], dtype=np.float64),
                np.asarray(gate_validation[1], dtype=np.float64))
    if held is not None:
        model.validate_gate(*held, groups=gate_groups)
    return model, history
