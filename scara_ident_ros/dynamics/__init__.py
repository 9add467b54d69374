"""SCARA physics in pure numpy: parameters, rigid-body model and linear regressor."""
from __future__ import annotations

from scara_ident_ros.dynamics.model import ScaraModel
from scara_ident_ros.dynamics.params import ParamError, ScaraParams
from scara_ident_ros.dynamics.regressor import (PARAMETER_NAMES, LeastSquaresIdentifier,
                                                base_parameters, regressor)

__all__ = ['ScaraParams', 'ParamError', 'ScaraModel', 'PARAMETER_NAMES', 'regressor',
           'base_parameters', 'LeastSquaresIdentifier']
