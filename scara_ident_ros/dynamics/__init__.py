"""Robot physics, pure numpy: any robot's rigid-body model and friction, identified.

The physical model of any URDF robot (Pinocchio) lives in its own modules, imported by
name so that users of the SCARA's closed form do not load Pinocchio: ``physical_model``
(base parameters, rotor inertias, friction and offsets; the estimator contract),
``base_reduction``, ``physical_options``, ``consistent_parameters`` (pseudo-inertia LMI),
``recursive_least_squares`` (online), ``urdf_limits``/``joint_limits`` and ``urdf_export``.
The SCARA also has its Lagrangian closed form (``model``, ``params``, ``regressor``, exported
here): the paper's equations (``../shared/reference/scara-model.md``), which ``scara_sim``
integrates for any ``ScaraParams`` file (other masses and lengths need no URDF) and which
test_model.py checks against Pinocchio on ``urdf/scara.urdf``. The hybrid (this physics plus
a learnt residual) is a learner: :mod:`scara_ident_ros.learners.hybrid_model`.
"""
from __future__ import annotations

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ParamError, ScaraParams
from scara_ident_ros.dynamics.regressor import (PARAMETER_NAMES, LeastSquaresIdentifier,
                                                base_parameters, regressor)

__all__ = ['ScaraParams', 'ParamError', 'ScaraModel', 'PARAMETER_NAMES', 'regressor',
           'base_parameters', 'LeastSquaresIdentifier']
