"""Friction-step initialisation: units that are steps of one input at zero."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.nn import FeedForwardNet
from scara_ident_ros.nn.friction_steps import set_step_units
from scara_ident_ros.nn.network import forward_scaled


def test_step_units_are_steps_of_one_input_at_zero() -> None:
    """``set_step_units``: unit u is k·σ(2·x_i / w) of its input alone; the others and the
    output layer keep their weights."""
    net = FeedForwardNet(6, 10, 2, 'sigmoid', seed=1)
    before = net.get_theta()
    set_step_units(net, [2, 3], [0.1, 0.01])
    xs = np.random.default_rng(0).uniform(-1, 1, (200, 6))
    h = forward_scaled(net, xs).h
    k = net.constants.k
    for unit, (width, column) in enumerate([(0.1, 2), (0.1, 3), (0.01, 2), (0.01, 3)]):
        np.testing.assert_allclose(h[:, unit], k / (1 + np.exp(-2 * xs[:, column] / width)),
                                   rtol=1e-12, atol=1e-15)
    Vt_before, Wt_before = net.unpack(before)
    Vt, Wt = net.unpack(net.theta)
    np.testing.assert_array_equal(Vt[:, 4:], Vt_before[:, 4:])
    np.testing.assert_array_equal(Wt, Wt_before)


@pytest.mark.parametrize('inputs, widths, match', [
    ([6], [0.1], 'inputs'), ([0], [0.0], 'widths'), ([0], [float('nan')], 'widths'),
    ([0, 1, 2, 3], [0.1, 0.2, 0.3], 'hidden units')])
def test_step_units_refuse_what_they_cannot_build(inputs: list[int], widths: list[float],
                                                  match: str) -> None:
    net = FeedForwardNet(6, 10, 2, 'sigmoid')
    before = net.get_theta()
    with pytest.raises(ValueError, match=match):
        set_step_units(net, inputs, widths)
    np.testing.assert_array_equal(net.theta, before)
