"""A physical model's options, chosen on validation data: Coulomb shape, offsets, coupling.

A robot's Coulomb friction changes sign with q', but how sharply depends on the drive:
sign(q') is the ideal step, tanh(q'/ε) a smooth one, and the q'' estimated from q' blurs
any step over the estimate's window. The held-out error depends on matching that
sharpness: on two simulated robots whose friction steps differ, the best fixed shape of one
is far worse than the best on the other (benchmarks/physical.md). No single shape is right
for every robot, so the fit tries each of :data:`CANDIDATES` by least squares on the
training samples and keeps the one of lowest mean validation NMSE: a few more linear
fits.

The same holds for what a real arm adds (:func:`select_options`): an effort offset per joint
(torque sensors drift, motor currents carry a bias) and the friction of coupled motors on
both joints (the TX40's wrist, joints 5 and 6). Each is a few columns; a newcomer cannot
know which the arm needs, so they are added greedily, each kept if it lowers the mean
validation NMSE by more than :data:`MIN_GAIN` of it, judged on *later motion* when
``scara-ident train`` has it; likewise the Coulomb shape stays tanh(q'/:data:`COULOMB_EPS`)
unless another candidate beats it by that much. The bar is high because a few seconds of
later motion rank options only roughly: with a 2 % bar and the lowest-scoring shape, TIAGo's
model took a Coulomb ε of 0.02, offsets, asymmetric friction and a coupling that lowered the
later-motion score (0.54 → 0.44) and raised two joints' NMSE on the motion after it
(0.28 → 0.48, 0.25 → 0.58); the TX40's took sign(q') for a 4 % lower score and predicted the
motion after it 2-6 times worse on joints 1-4 than with tanh. Least squares weighted
per joint by 1/its residual RMS (as identification often is: unweighted, a torso's or
shoulder's large efforts decide the shared parameters at a wrist's expense) is left to the
caller: on these recordings it won or lost by chance (:data:`WEIGHTED`). Asymmetric
Coulomb friction, nearly collinear with the offsets, is left to ``--asymmetric``. On the TX40 the
coupling of joints 5 and 6 takes joint 5's NMSE on the last 30 % of the recording from 9.4 to
0.67 (benchmarks/later_motion.md).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from scara_ident_ros.dynamics.least_squares import BlockLeastSquares, residual_weights
from scara_ident_ros.dynamics.physical_model import COULOMB_EPS, PhysicalModel

__all__ = ['CANDIDATES', 'CoulombChoice', 'MIN_GAIN', 'MIN_NMSE_GAIN', 'OptionChoice',
           'WEIGHTED',
           'select_coulomb', 'select_options']

#: Shapes tried: sign, and tanh(q'/ε) for ε in rad/s (m/s for a prismatic joint).
CANDIDATES: tuple[tuple[str, float], ...] = (('sign', 1.0), ('tanh', 0.005), ('tanh', 0.01),
                                             ('tanh', 0.02), ('tanh', 0.05), ('tanh', 0.1),
                                             ('tanh', 0.2))
#: An option is kept if it lowers the mean validation NMSE by more than this share of it.
MIN_GAIN = 0.15
#: ... and by at least this much of the efforts' variance: on a model that already explains
#: all but 1e-5 of it (a simulated arm, the q'' estimate's error left), a coupling that
#: fits part of that error is not a property of the robot.
MIN_NMSE_GAIN = 1e-3
#: Least squares weighted per joint by 1/its residual RMS (``PhysicalModel(weighted=True)``)
#: is not chosen by the later motion: weighted, the TX40's physical model predicted its last
#: 30 % up to 10 % worse (joint 5: NMSE 0.533 against 0.485) and TIAGo's arm_4 14 % better,
#: while the later motion inside their training spans ranked them the other way round (TX40
#: 0.184 weighted against 0.219, TIAGo 0.626 against 0.541). Equal weights stay unless a
#: caller fixes ``weighted``.
WEIGHTED = False
#: Samples of each set the options are scored on (a seeded draw of larger sets): some 60
#: parameters need far fewer, and a 5 kHz recording's neighbours are nearly equal.
SCORE_SAMPLES = 8000


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
    scorer = _Scorer(models[0], (x, y), (xv, yv), block=block)
    score = [scorer.score(model) for model in models]
    scores = {_label(c, e): v for (c, e), v in zip(candidates, score)}
    best = int(np.argmin(score))
    coulomb, eps = candidates[best]
    return models[best].fit(x, y), CoulombChoice(coulomb, eps, scores)


class _Scorer:
    """The mean validation NMSE of a model's least-squares fit, for models of one URDF and
    joints that differ in their friction and offset columns: the rigid-body regressor (one
    Pinocchio call per sample, the costly part) is computed once per block of the training
    and validation samples and shared by every model scored."""

    def __init__(self, first: PhysicalModel, train: tuple[np.ndarray, np.ndarray],
                 validation: tuple[np.ndarray, np.ndarray], *, block: int) -> None:
        (x, self._y), (xv, self._yv) = train, validation
        self._first, n = first, first.n_joints

        def blocks(data: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
            return [(first.base_regressor(p[:, :n], p[:, n:2 * n], p[:, 2 * n:]),
                     p[:, n:2 * n]) for p in (data[i:i + block]
                                              for i in range(0, data.shape[0], block))]

        self._block, self._train, self._validation = block, blocks(x), blocks(xv)
        variance = self._yv.var(axis=0)
        self._variance = np.where(variance > 0.0, variance, 1.0)

    def score(self, model: PhysicalModel) -> float:
        """Fit ``model``'s θ by least squares (weighted if it is) on the training samples
        (the model itself is left as it is); return its mean NMSE over the joints on the
        validation samples."""
        if (model.standard_names != self._first.standard_names or not np.array_equal(
                model.reduction.independent, self._first.reduction.independent)):
            raise ValueError('the candidates must be models of one URDF and joints')
        joints = [BlockLeastSquares(model.n_parameters) for _ in range(model.n_joints)]
        for k, (base, qd) in enumerate(self._train):
            rows = model.regressor_from_base(base, qd)
            y = self._y[k * self._block:(k + 1) * self._block]
            for j, system in enumerate(joints):
                system.add(rows[:, j, :], y[:, j])
        theta = BlockLeastSquares.stack(
            joints, residual_weights(joints, self._y.shape[0]) if model.weighted
            else np.ones(model.n_joints)).solve()
        squares = np.zeros(model.n_joints)
        for k, (base, qd) in enumerate(self._validation):
            error = (model.regressor_from_base(base, qd) @ theta
                     - self._yv[k * self._block:(k + 1) * self._block])
            squares += np.sum(error ** 2, axis=0)
        return float(np.mean(squares / self._yv.shape[0] / self._variance))


def _label(coulomb: str, eps: float) -> str:
    return 'sign' if coulomb == 'sign' else f'tanh {eps:g}'


@dataclass(frozen=True)
class OptionChoice:
    """The options kept by :func:`select_options`, and the steps that chose them.

    Attributes
    ----------
    options : dict of str to object
        Keyword options of the model's constructor: ``coulomb``, ``coulomb_eps``,
        ``offsets``, ``coupled`` (a tuple of joint-name pairs), ``weighted``.
    scores : dict of str to float
        Every candidate tried, by its options' label (``'tanh 0.05'``, ``'tanh 0.05,
        offsets'``, ``'tanh 0.05, coupled joint_5,joint_6'``), in the order tried → mean
        validation NMSE over joints.
    """

    options: dict[str, object]
    scores: dict[str, float]

    @property
    def label(self) -> str:
        """``'tanh 0.05, offsets, coupled joint_5,joint_6'``."""
        o = self.options
        parts = [_label(str(o['coulomb']), float(o['coulomb_eps']))]  # type: ignore[arg-type]
        parts += ['offsets'] if o.get('offsets') else []
        parts += ['weighted'] if o.get('weighted') else []
        parts += [f'coupled {a},{b}' for a, b in o['coupled']]  # type: ignore[attr-defined]
        return ', '.join(parts)


def select_options(build: Callable[..., PhysicalModel],
                   train: tuple[ArrayLike, ArrayLike], validation: tuple[ArrayLike, ArrayLike],
                   *, fixed: dict[str, object] | None = None, block: int = 2048
                   ) -> tuple[PhysicalModel, OptionChoice]:
    """Choose the Coulomb shape, then add offsets and each neighbouring pair's coupling
    greedily (module docstring); fit the result.

    Parameters
    ----------
    build : callable
        ``build(**options)`` returns a fresh model of one URDF and joints with those
        constructor options (``coulomb``, ``coulomb_eps``, ``offsets``, ``coupled``,
        ``weighted``) and
        the caller's others.
    train, validation : (X, Y)
        Inputs (N, 3n) = [q, q', q''] and efforts (N, n); validation, at least 2 samples,
        should be later motion.
    fixed : dict, optional
        Options the caller imposes (not chosen): any of the five keys above.
    block : int
        Samples per block of the regressor.

    Returns
    -------
    model : PhysicalModel
        Built with the chosen options and fitted on ``train`` (the caller's ``consistent``
        fit, if it asked for one).
    choice : OptionChoice
    """
    fixed = dict(fixed or {})
    x_all, y_all = (np.asarray(a, dtype=np.float64) for a in train)
    x, y = _draw(x_all, y_all)
    xv, yv = _draw(*(np.asarray(a, dtype=np.float64) for a in validation))
    if xv.shape[0] < 2:
        raise ValueError('choosing the physical model\'s options needs validation samples')
    first = build(coulomb='tanh', coulomb_eps=COULOMB_EPS, offsets=False, coupled=(),
                  weighted=False)
    scorer = _Scorer(first, (x, y), (xv, yv), block=block)
    scores: dict[str, float] = {}

    def score(options: dict[str, object]) -> float:
        value = scorer.score(build(**options))
        scores[OptionChoice(options, {}).label] = value
        return value

    options: dict[str, object] = {'offsets': False, 'coupled': (), 'weighted': WEIGHTED}
    options.update({k: v for k, v in fixed.items() if k in options})
    options['coulomb'] = fixed.get('coulomb', 'tanh')
    options['coulomb_eps'] = fixed.get('coulomb_eps', COULOMB_EPS)
    best = score(options)
    if 'coulomb' not in fixed:  # another shape only if clearly better
        tried = {(c, e): score({**options, 'coulomb': c, 'coulomb_eps': e})
                 for c, e in CANDIDATES}
        (coulomb, eps), value = min(tried.items(), key=lambda item: item[1])
        if _gains(value, best):
            best = value
            options.update(coulomb=coulomb, coulomb_eps=eps)
    names = first.joint_names
    steps: list[tuple[str, dict[str, object]]] = []
    if 'offsets' not in fixed:
        steps.append(('+ offsets', {'offsets': True}))
    if 'coupled' not in fixed:
        steps += [(f'+ coupled {a},{b}', {'coupled': ((a, b),)})
                  for a, b in zip(names[:-1], names[1:])]
    while steps:
        tried_steps = []
        for label, change in steps:
            merged = dict(options)
            for key, setting in change.items():
                merged[key] = (tuple(options['coupled']) + tuple(setting)  # type: ignore
                               if key == 'coupled' else setting)
            tried_steps.append((score(merged), label, merged))
        value, label, merged = min(tried_steps, key=lambda item: item[0])
        if not _gains(value, best):
            break
        best, options = value, merged
        steps = [step for step in steps if step[0] != label]
    return build(**options).fit(x_all, y_all), OptionChoice(options, scores)


def _gains(value: float, best: float) -> bool:
    """Whether a score ``value`` beats ``best`` by more than :data:`MIN_GAIN` of it and by
    more than :data:`MIN_NMSE_GAIN`."""
    return best - value > max(MIN_GAIN * best, MIN_NMSE_GAIN)


def _draw(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At most :data:`SCORE_SAMPLES` rows of x and y, a seeded draw in time order."""
    if x.shape[0] <= SCORE_SAMPLES:
        return x, y
    rows = np.sort(np.random.default_rng(0).choice(x.shape[0], SCORE_SAMPLES, replace=False))
    return x[rows], y[rows]
