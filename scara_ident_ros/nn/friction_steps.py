"""Friction-step initialisation: hidden units that start as steps of single inputs at 0.

It gives a sigmoid network the shape of a robot's Coulomb friction (each joint's effort
jumps at zero speed) from the start. From random weights of ±weight_scale,
Levenberg–Marquardt needs input weights of several hundred to fit such a step, and grows
them too slowly (``benchmarks/learning_curves.md``).
"""
from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from scara_ident_ros.nn.network import FeedForwardNet

__all__ = ['set_step_units']


def set_step_units(net: FeedForwardNet, inputs: Sequence[int], widths: Sequence[float]
                   ) -> None:
    """Start hidden units of ``net`` as steps of single inputs at 0, one per input and width.

    Unit ``u`` (0, 1, … in the order ``widths`` × ``inputs``) gets the net input
    z = 2·x_i / w of scaled input ``x_i`` alone (its other input weights 0, its bias ``b``),
    so that a sigmoid unit is k·σ(2·x_i / w) = k·(1 + tanh(x_i / w)) / 2: a step of
    half-width ``w`` (scaled units) at x_i = 0 (a SLOG or MSLOG unit, a wavelet, becomes a
    narrow wavelet there instead). The other units keep their weights, the output weights
    are not changed; training moves these units like any other.

    Parameters
    ----------
    net : FeedForwardNet
    inputs : sequence of int
        Input columns (e.g. the joint velocities, n..2n−1 of [q, q', q'']).
    widths : sequence of float
        Half-widths, in scaled units (a fraction of the input's half-range), each > 0.

    Raises
    ------
    ValueError
        If an input is out of range, a width is not positive and finite, or there are
        more steps than hidden units.
    """
    n_in, n_hid = net.n_inputs, net.n_hidden
    Vt = net.unpack(net.theta)[0]
    inputs = [operator.index(i) for i in inputs]
    widths = [float(w) for w in widths]
    if any(not 0 <= i < n_in for i in inputs):
        raise ValueError(f'step inputs must be in [0, {n_in}), got {inputs}')
    if any(not (math.isfinite(w) and w > 0.0) for w in widths):
        raise ValueError(f'step widths must be positive, got {widths}')
    if len(inputs) * len(widths) > n_hid:
        raise ValueError(f'{len(widths)} step widths × {len(inputs)} inputs need more '
                         f'than the {n_hid} hidden units')
    units = range(len(inputs) * len(widths))
    for unit, (width, column) in zip(units, itertools.product(widths, inputs)):
        Vt[:, unit] = 0.0
        Vt[column, unit] = 2.0 * net.constants.a / width
        Vt[n_in, unit] = net.constants.b
