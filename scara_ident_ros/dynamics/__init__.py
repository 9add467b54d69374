"""Robot physics: the SCARA's parameters, rigid-body model and linear regressor (pure numpy).

The physical model of any URDF robot (Pinocchio) lives in its own modules, imported by
name so that the SCARA's users do not load it: ``physical_model`` (base parameters and
friction), ``base_reduction``, ``coulomb_selection``, ``hybrid_model`` (plus a residual
network) and ``recursive_least_squares`` (online, for either).
"""
from __future__ import annotations

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ParamError, ScaraParams
from scara_ident_ros.dynamics.regressor import (PARAMETER_NAMES, LeastSquaresIdentifier,
                                                base_parameters, regressor)

__all__ = ['ScaraParams', 'ParamError', 'ScaraModel', 'PARAMETER_NAMES', 'regressor',
           'base_parameters', 'LeastSquaresIdentifier']
