"""The paper's three networks (FFMW, FFW, FFS), their default hyperparameters and factory.

One table and one factory used by the identifier node, ``scara-ident compare``, ``train``
and ``tables``, so that every part of the project means the same thing by "FFMW".
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.friction_steps import set_step_units

__all__ = ['HIDDEN_UNITS', 'Method', 'METHODS', 'FRICTION_STEP_WIDTHS', 'method',
           'make_network', 'limit_scaling']

#: Hidden units of a network: the paper's 12-40-4 (80 and 160 did not change the picture on
#: the real recordings: within 6 % on the WAM and TIAGo, worse on the TX40;
#: benchmarks/networks_real.md).
HIDDEN_UNITS = 40


@dataclass(frozen=True)
class Method:
    """A network of the paper: its hidden activation and online-learning defaults.

    Attributes
    ----------
    name : str
        Key used on the command line and in parameters (``'ffmw'``).
    label : str
        Name in the paper (``'FFMW'``).
    activation : str
        Hidden activation, a key of :data:`scara_ident_ros.nn.ACTIVATIONS`.
    learning_rate, momentum : float
        Defaults of online learning (``partial_fit``), chosen by the documented search
        of ``scara-ident compare`` on training data only.
    weight_scale : float
        Initial spread of the hidden units' net input.

    Notes
    -----
    The values in :data:`METHODS` are the choices of the default ``scara-ident compare``
    (grid: learning rate 0.03–3, momentum 0/0.5/0.9, weight scale 1/4; the first 10 s of
    the simulated training stream; each point learns 5 s online from seeds 0 and 1 and is
    scored by the worst a-priori NMSE over the next 5 s, among points whose next larger
    learning rate is still stable; see ``scara_ident_ros.paper.hyperparameters``).
    """

    name: str
    label: str
    activation: str
    learning_rate: float
    momentum: float
    weight_scale: float = 2.0


METHODS: dict[str, Method] = {
    'ffmw': Method('ffmw', 'FFMW', 'mslog', learning_rate=0.1, momentum=0.5, weight_scale=4.0),
    'ffw': Method('ffw', 'FFW', 'slog', learning_rate=0.3, momentum=0.5, weight_scale=4.0),
    'ffs': Method('ffs', 'FFS', 'sigmoid', learning_rate=0.1, momentum=0.5, weight_scale=4.0),
}


def method(name: str) -> Method:
    """Return the method called ``name`` (case-insensitive).

    Raises
    ------
    ValueError
        If there is no such method; the message lists the known ones.
    """
    try:
        return METHODS[name.lower()]
    except KeyError:
        raise ValueError(f'unknown method {name!r}; known: {", ".join(METHODS)}') from None


#: Half-widths of the friction steps (``make_network(friction_steps=True)``), as fractions
#: of each joint's velocity limit: a geometric grid, factor 4, so that one of them is within
#: a factor 2 of any Coulomb step 0.0125–12.8 % of the limit wide (the simulated SCARAs':
#: 0.19 % for joint 4 to 4.5 % for joint 3). Without the widest, joint 3 of another SCARA
#: missed 1e-3 on one seed of 5. Measured (FFS, ``lm``, 120 s of ``sequence``, Coulomb steps
#: 5× sharper and 4× wider than the simulator's too): benchmarks/learning_curves.md.
FRICTION_STEP_WIDTHS = (0.064, 0.016, 0.004, 0.001, 0.00025)


def make_network(name: str, n_joints: int, *, n_hidden: int = HIDDEN_UNITS, seed: int = 0,
                 learning_rate: float | None = None, momentum: float | None = None,
                 weight_scale: float | None = None, k: float | None = None,
                 a: float | None = None, b: float | None = None,
                 friction_steps: bool = False) -> FeedForwardNet:
    """Build the (3·n_joints)-n_hidden-n_joints network of method ``name``.

    Hyperparameters left as None take the method's defaults (:data:`METHODS`) and, for
    k, a, b, the activation's (MSLOG: 2.5, 5, 5). The scaling is left unset.

    With ``friction_steps``, the first hidden units start as steps of each joint's speed
    q' at 0, one per joint and width of :data:`FRICTION_STEP_WIDTHS`
    (`friction_steps.set_step_units`; with limit scaling a width is a fraction of
    the velocity limit): the shape of Coulomb friction, which Levenberg–Marquardt from
    random weights fits too slowly online. Steps take at most half the hidden units (all
    five widths for 4 joints and 40 units; for more joints fewer widths, widest first),
    so that at least as many units start random for the rest of the dynamics.
    """
    spec = method(name)
    network = FeedForwardNet(
        3 * n_joints, n_hidden, n_joints, spec.activation, seed=seed, k=k, a=a, b=b,
        weight_scale=spec.weight_scale if weight_scale is None else weight_scale,
        learning_rate=spec.learning_rate if learning_rate is None else learning_rate,
        momentum=spec.momentum if momentum is None else momentum)
    if friction_steps:
        widths = FRICTION_STEP_WIDTHS[:n_hidden // 2 // n_joints]
        set_step_units(network, range(n_joints, 2 * n_joints), widths)
    return network


def limit_scaling(position_min: ArrayLike, position_max: ArrayLike, velocity_max: ArrayLike,
                  acceleration_max: ArrayLike,
                  effort_max: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                  np.ndarray]:
    """Input and output ranges of the network from a robot's joint limits.

    Parameters
    ----------
    position_min, position_max : array_like of shape (n,)
        Joint position limits (rad or m).
    velocity_max, acceleration_max, effort_max : array_like of shape (n,)
        Symmetric limits of velocity (rad/s, m/s), acceleration (rad/s², m/s²) and
        effort (N·m, N).

    Returns
    -------
    x_min, x_max : ndarray of shape (3n,)
        Input ranges in the order [q, q', q''].
    y_min, y_max : ndarray of shape (n,)
        Output ranges.
    """
    qd = np.abs(np.asarray(velocity_max, float))
    qdd = np.abs(np.asarray(acceleration_max, float))
    tau = np.abs(np.asarray(effort_max, float))
    x_min = np.concatenate([np.asarray(position_min, float), -qd, -qdd])
    x_max = np.concatenate([np.asarray(position_max, float), qd, qdd])
    return x_min, x_max, -tau, tau
