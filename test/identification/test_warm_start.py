"""A saved model is refused, in one line, where it cannot go on identifying."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification import ModelMismatch, check_warm_start
from scara_ident_ros.nn.presets import make_network
from scara_ident_ros.nn import FeedForwardNet

NAMES = ['joint1', 'joint2']


def named(names: list[str] | None, method: str = 'ffmw') -> FeedForwardNet:
    network = make_network(method, 2, n_hidden=3)
    if names is not None:
        network.metadata['joint_names'] = np.array(names)
    return network


def test_the_saved_joints_are_taken_when_none_are_given() -> None:
    assert check_warm_start(named(NAMES), source='m.npz', method='ffmw') == NAMES
    assert check_warm_start(named(NAMES), NAMES, source='m.npz') == NAMES
    assert check_warm_start(named(None), source='m.npz') == []
    assert named(None).joint_names is None
    assert named(NAMES).joint_names == tuple(NAMES)


@pytest.mark.parametrize(('network', 'names', 'method', 'message'), [
    (FeedForwardNet(5, 3, 2), [], None, r'm\.npz: a network with 5 inputs and 2 outputs is '
                                        'not an inverse-dynamics model'),
    (named(NAMES, 'ffs'), [], 'ffmw', 'is a ffs model, not one of method ffmw'),
    (named(NAMES), NAMES[::-1], None, r"trained for joints \['joint1', 'joint2'\] \(in that "
                                      'order'),
    (named(NAMES), ['joint1', 'joint3'], None, 'trained for joints'),
    (named(None), ['a', 'b', 'c'], None, 'has 2 outputs, not 3 joints'),
    (named(['a', 'b', 'c']), [], None, 'has 2 outputs, not 3 joints'),
])
def test_mismatches_are_one_line(network: FeedForwardNet, names: list[str],
                                 method: str | None, message: str) -> None:
    with pytest.raises(ModelMismatch, match=message) as raised:
        check_warm_start(network, names, source='m.npz', method=method)
    assert '\n' not in str(raised.value) and isinstance(raised.value, ValueError)
