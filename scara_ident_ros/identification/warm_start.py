"""Whether a saved network can go on identifying: its shape, method and joints.

The identifier continues from a saved model (``model_path``, or what ``save_path`` holds)
and ``scara-ident evaluate`` scores one on a bag: both check it here, so that a model of
another method, of other joints or of joints in another order is refused with one line
instead of feeding each joint's values to another joint's weights.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.nn.presets import METHODS
from scara_ident_ros.nn import FeedForwardNet

__all__ = ['ModelMismatch', 'check_warm_start', 'model_joint_names']


class ModelMismatch(ScaraIdentError, ValueError):
    """A network file cannot be used with a recording or a robot (one-line message)."""


def model_joint_names(network: FeedForwardNet) -> tuple[str, ...] | None:
    """The joints the network was trained for, in output order, or None if not recorded."""
    names = network.metadata.get('joint_names')
    if names is None:
        return None
    return tuple(str(name) for name in np.atleast_1d(names))


def check_warm_start(network: FeedForwardNet, names: Sequence[str] = (), *, source: str,
                     method: str | None = None) -> list[str]:
    """Check that ``network`` maps [q, q', q''] to the efforts of ``names``; return the joints.

    ``names`` empty accepts any joints and returns those the network recorded (maybe
    none); ``method`` is checked against its hidden activation; ``source`` names it in
    messages.

    Raises
    ------
    ModelMismatch
        If it has not 3n inputs for n outputs, has another method's activation, recorded
        other joints or the same in another order, or has not one output per joint.
    """
    n = network.n_outputs
    if network.n_inputs != 3 * n:
        raise ModelMismatch(f'{source}: a network with {network.n_inputs} inputs and {n} '
                            'outputs is not an inverse-dynamics model (3n inputs [q, qd, qdd] '
                            'for n joint efforts)')
    activation = METHODS[method].activation if method is not None else network.activation
    if network.activation != activation:
        raise ModelMismatch(f'model {source} has {network.activation} hidden units, not the '
                            f"{activation} of method {method}: set method to the model's")
    saved = list(model_joint_names(network) or ())
    # The network's inputs and outputs are in the saved order: another order would feed each
    # joint's values to another joint's weights.
    if names and saved and list(names) != saved:
        raise ModelMismatch(f'model {source} was trained for joints {saved} (in that order), '
                            f'not joint_names {list(names)}')
    names = list(names) or saved
    if names and len(names) != n:
        raise ModelMismatch(f'model {source} has {n} outputs, not {len(names)} joints')
    return names
