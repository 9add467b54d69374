"""Whether an arm's links meet: Pinocchio's collision model of a URDF's collision geometry.

:class:`SelfCollision` loads the ``<collision>`` geometry of a URDF (meshes found through
``package://`` in the folders above the URDF and in ``AMENT_PREFIX_PATH``'s ``share``) and
checks every pair of links, except those that touch already where the arm is built to touch:
links joined by a joint, and pairs in contact at the middle of the ranges (a URDF's
collision meshes often overlap at their joints). The other joints of the URDF (a gripper's
fingers) stay at their neutral position. :func:`self_collision` is None for a URDF without
collision geometry, or whose meshes are not found: nothing to check.
"""
from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ['SelfCollision', 'self_collision']


class SelfCollision:
    """The collision pairs of a URDF's links that may meet, checked at joint positions.

    Parameters
    ----------
    model, geometry : pinocchio.Model, pinocchio.GeometryModel
        The whole URDF's kinematics and its collision geometry.
    joint_names : sequence of str
        The joints whose positions are given, in that order.
    centre : ndarray of shape (n,)
        A configuration of those joints (rad, m) at which touching pairs are left out.
    """

    def __init__(self, model: Any, geometry: Any, joint_names: Sequence[str],
                 centre: NDArray[np.float64]) -> None:
        import pinocchio as pin

        self._pin, self._model, self.geometry = pin, model, geometry
        self._index = np.array([model.joints[model.getJointId(name)].idx_q
                                for name in joint_names])
        objects = geometry.geometryObjects
        geometry.addAllCollisionPairs()
        joined = {(model.parents[jid], jid) for jid in range(1, model.njoints)}
        for k in reversed(range(len(geometry.collisionPairs))):
            pair = geometry.collisionPairs[k]
            a, b = objects[pair.first].parentJoint, objects[pair.second].parentJoint
            if a == b or (a, b) in joined or (b, a) in joined:
                geometry.removeCollisionPair(pair)
        self._data, self._geometry_data = model.createData(), pin.GeometryData(geometry)
        for pair in self._colliding_pairs(np.asarray(centre, dtype=float)):
            geometry.removeCollisionPair(pair)
        self._geometry_data = pin.GeometryData(geometry)

    @property
    def n_pairs(self) -> int:
        """Pairs of collision objects checked."""
        return len(self.geometry.collisionPairs)

    def colliding(self, q: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether any checked pair meets at each row of q (N, n); shape (N,)."""
        rows = np.atleast_2d(np.asarray(q, dtype=float))
        return np.array([bool(self._colliding_pairs(row, stop_at_first=True)) for row in rows])

    def _colliding_pairs(self, q: NDArray[np.float64], *, stop_at_first: bool = False
                         ) -> list[Any]:
        pin, model = self._pin, self._model
        full = pin.neutral(model)
        full[self._index] = q
        pin.computeCollisions(model, self._data, self.geometry, self._geometry_data, full,
                              stop_at_first)
        return [self.geometry.collisionPairs[k] for k, result in
                enumerate(self._geometry_data.collisionResults) if result.isCollision()]


def self_collision(urdf_file: str | Path, joint_names: Sequence[str],
                   centre: NDArray[np.float64]) -> SelfCollision | None:
    """The URDF's self-collision check (:class:`SelfCollision`), or None if it has no
    collision geometry that loads."""
    import pinocchio as pin

    path = Path(urdf_file).resolve()
    folders = [str(parent) for parent in path.parents]
    folders += [str(Path(prefix) / 'share') for prefix in
                os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if prefix]
    try:
        model = pin.buildModelFromUrdf(str(path))
        geometry = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.COLLISION,
                                         package_dirs=folders)
    except (RuntimeError, ValueError, OSError):
        return None
    if len(geometry.geometryObjects) < 2:
        return None
    return SelfCollision(model, geometry, joint_names, centre)
