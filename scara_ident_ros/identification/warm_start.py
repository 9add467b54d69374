"""Whether a saved model can go on identifying: its shape, method and joints.

The identifier continues from a saved model (``model_path``, or what ``save_path`` holds)
and ``scara-ident evaluate`` scores one on a bag: both check it here, so that a model of
another method, of other joints or of joints in another order is refused with one line
instead of feeding each joint's values to another joint's weights. Any model of the
estimator contract (:class:`~scara_ident_ros.estimator.Estimator`) is checked the same way.
"""
from __future__ import annotations

from collections.abc import Sequence

from scara_ident_ros.errors import ScaraIdentError
from scara_ident_ros.estimator import Estimator

__all__ = ['ModelMismatch', 'check_warm_start']


class ModelMismatch(ScaraIdentError, ValueError):
    """A model file cannot be used with a recording or a robot (one-line message)."""


def check_warm_start(model: Estimator, names: Sequence[str] = (), *, source: str,
                     method: str | None = None) -> list[str]:
    """Check that ``model`` maps [q, q', q''] to the efforts of ``names``; return the joints.

    ``names`` empty accepts any joints and returns those the model recorded (maybe none);
    ``method`` is checked against the model's (a network's: from its hidden activation);
    ``source`` names it in messages.

    Raises
    ------
    ModelMismatch
        If it has not 3n inputs for n outputs, is another method's model, recorded other
        joints or the same in another order, or has not one output per joint.
    """
    n = model.n_outputs
    if model.n_inputs != 3 * n:
        raise ModelMismatch(f'{source}: a {model.kind} with {model.n_inputs} inputs and {n} '
                            'outputs is not an inverse-dynamics model (3n inputs [q, qd, qdd] '
                            'for n joint efforts)')
    if method is not None and model.method != method:
        raise ModelMismatch(f'model {source} is a {model.method} model, not one of method '
                            f"{method}: set method to the model's")
    saved = list(model.joint_names or ())
    # The model's inputs and outputs are in the saved order: another order would feed each
    # joint's values to another joint's weights.
    if names and saved and list(names) != saved:
        raise ModelMismatch(f'model {source} was trained for joints {saved} (in that order), '
                            f'not joint_names {list(names)}')
    names = list(names) or saved
    if names and len(names) != n:
        raise ModelMismatch(f'model {source} has {n} outputs, not {len(names)} joints')
    return names
