"""The sizes of an inverse-dynamics map of n joints, written once for every model of them.

A model of n joints maps x = [q, q', q''] (3n inputs: rad or m, /s, /s²) to the n joint
efforts (N·m or N): :class:`~scara_ident_ros.dynamics.physical_model.PhysicalModel` and
:class:`~scara_ident_ros.identification.streamed_estimator.StreamedEstimator` take their
``n_joints``, ``n_inputs`` and ``n_outputs`` from :class:`JointSizes`.
"""
from __future__ import annotations

__all__ = ['JointSizes']


class JointSizes:
    """``n_joints``, ``n_inputs`` and ``n_outputs`` of a model of ``_n`` joints.

    A class that mixes this in sets ``self._n`` (the number of joints n) in its constructor.
    """

    _n: int

    @property
    def n_joints(self) -> int:
        """Number of modelled joints n."""
        return self._n

    @property
    def n_inputs(self) -> int:
        """3n: [q, q', q''] like a network's inputs."""
        return 3 * self._n

    @property
    def n_outputs(self) -> int:
        """n joint efforts."""
        return self._n
