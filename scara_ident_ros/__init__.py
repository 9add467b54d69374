"""Online identification of robot inverse dynamics (ROS 2): the models a user fits on arrays.

Every effort model keeps one estimator contract (:mod:`scara_ident_ros.estimator`)::

    from scara_ident_ros import FeedForwardNet, load_model

    model = FeedForwardNet(21, 40, 7, 'sigmoid')   # X (N, 3n) = [q, q', q''], Y (N, n)
    # or ExactGP(), SparseSpectrumGP(1000), LinearFeatures(),
    # PhysicalModel.from_urdf_file(...)
    model.fit(X, Y)
    model.score(X_test, Y_test)                    # R²
    model.save('wam.npz')
    same = load_model('wam.npz')                   # the kind is read from the file

An online identifier with the node's settings, without a node::

    from scara_ident_ros import IdentifierSettings, build_identifier

    identifier = build_identifier(names, IdentifierSettings.defaults(method='linear'))
    results = identifier.process(stamp_ns, names, q, qd, effort)   # one sample at a time

Everything is imported on first use: the physical models bring Pinocchio, and every
interpreter of the venv imports this package at start-up (``nodes/rosenv.py``'s ``.pth``),
which must not cost it numpy's import.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from scara_ident_ros.estimator import (Estimator, OnlineEstimator, load_model, r2_score,
                                           register_kind)
    from scara_ident_ros.learners.hybrid_model import HybridModel
    from scara_ident_ros.dynamics.physical_model import PhysicalModel
    from scara_ident_ros.identification.identifier_builder import build_identifier
    from scara_ident_ros.identification.identifier_settings import IdentifierSettings
    from scara_ident_ros.learners.exact_gp import ExactGP
    from scara_ident_ros.learners.linear_features import LinearFeatures
    from scara_ident_ros.learners.sparse_spectrum_gp import SparseSpectrumGP
    from scara_ident_ros.nn.network import FeedForwardNet
    from scara_ident_ros.nn.presets import make_network

__all__ = ['Estimator', 'ExactGP', 'FeedForwardNet', 'HybridModel', 'IdentifierSettings',
           'LinearFeatures', 'OnlineEstimator', 'PhysicalModel', 'SparseSpectrumGP',
           'build_identifier', 'load_model', 'make_network', 'r2_score', 'register_kind']

_LAZY = {**dict.fromkeys(['Estimator', 'OnlineEstimator', 'load_model', 'r2_score',
                          'register_kind'], 'scara_ident_ros.estimator'),
         'FeedForwardNet': 'scara_ident_ros.nn.network',
         'make_network': 'scara_ident_ros.nn.presets',
         'PhysicalModel': 'scara_ident_ros.dynamics.physical_model',
         'HybridModel': 'scara_ident_ros.learners.hybrid_model',
         'SparseSpectrumGP': 'scara_ident_ros.learners.sparse_spectrum_gp',
         'ExactGP': 'scara_ident_ros.learners.exact_gp',
         'LinearFeatures': 'scara_ident_ros.learners.linear_features',
         'IdentifierSettings': 'scara_ident_ros.identification.identifier_settings',
         'build_identifier': 'scara_ident_ros.identification.identifier_builder'}


def __getattr__(name: str) -> Any:
    """The estimator contract and the model classes, imported when first asked for."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    import importlib

    return getattr(importlib.import_module(module), name)
