"""What an identifier's core is built from: :class:`CoreSettings`, and the methods it learns.

The settings are the ``identifier`` node's parameters of those names
(:mod:`scara_ident_ros.identification.parameters`, their one source of defaults):
``CoreSettings.of(node_parameters)`` in the node, ``CoreSettings.defaults(**changes)``
without one; :func:`~scara_ident_ros.identification.identifier_builder.build_identifier`
builds from them.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import MISSING, dataclass, fields
from typing import Any

from scara_ident_ros.identification.learner_methods import (GP_BUDGET, KERNEL_FEATURES,
                                                             LEARNER_BATCH, LEARNER_METHODS,
                                                             LEARNER_WARMUP)
from scara_ident_ros.nn.presets import METHODS

__all__ = ['CoreSettings', 'ONLINE_METHODS', 'PHYSICAL_METHODS']

#: Models on the robot's URDF (they need it): its rigid-body model alone, learnt by RLS, or
#: with an FFS network of its residual.
PHYSICAL_METHODS = ('physical', 'hybrid')
#: Every model an identifier learns online: the networks, the physical ones, the kernel
#: learners.
ONLINE_METHODS = (*METHODS, *PHYSICAL_METHODS, *LEARNER_METHODS)


@dataclass(frozen=True)
class CoreSettings:
    """The identifier's parameters the network and the core are built from.

    ``learning_rate`` 0 and a negative ``momentum`` take the method's defaults; ``k``,
    ``a``, ``b`` are used by ``ffmw`` only; ``max_gap`` is in seconds; a negative
    ``limit_margin`` checks no sample against the limits.
    """

    method: str
    hidden_units: int
    seed: int
    learning_rate: float
    momentum: float
    k: float
    a: float
    b: float
    trainer: str
    reservoir_size: int
    lm_steps: int
    lm_interval: int
    lm_nice: int
    lm_float64: bool
    lm_slow_share: float
    lm_friction_steps: bool
    validation_fraction: float
    validation_block: int
    mse_window: int
    learn: bool
    max_gap: float
    limit_margin: float
    min_joints: int
    derive_velocity: str = 'auto'
    kernel_features: int = KERNEL_FEATURES
    gp_budget: int = GP_BUDGET
    learner_batch: int = LEARNER_BATCH
    learner_warmup: int = LEARNER_WARMUP

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> CoreSettings:
        """The settings among ``values`` (e.g. all the node's parameters); a field with a
        default may be absent."""
        return cls(**{field.name: values[field.name] for field in fields(cls)
                      if field.name in values or field.default is MISSING})

    @classmethod
    def defaults(cls, **changes: Any) -> CoreSettings:
        """The node's defaults (:mod:`~scara_ident_ros.identification.parameters`), with
        ``changes`` (field names) instead of some.

        Raises
        ------
        TypeError
            If a name of ``changes`` is not a field.
        """
        from scara_ident_ros.identification.parameters import parameter_defaults

        unknown = sorted(set(changes) - {field.name for field in fields(cls)})
        if unknown:
            raise TypeError(f'CoreSettings has no fields {unknown}')
        return cls.of({**parameter_defaults(), **changes})
