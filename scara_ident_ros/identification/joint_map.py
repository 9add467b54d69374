"""Map a message's joints to the configured joint order, by name.

``sensor_msgs/JointState`` does not promise an order: a driver may publish the joints in any
order, or several drivers' states may be merged. Values are therefore never read by position
in the message but looked up by name.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.skip_reason import SkipReason

__all__ = ['JointMap']


class JointMap:
    """The configured joint order and the permutation that brings a message into it.

    Parameters
    ----------
    names : sequence of str, optional
        The joint order, e.g. ``('joint1', 'joint2', 'joint3', 'joint4')``. If omitted, the
        order is taken from the first message passed to :meth:`adopt`.
    n_joints : int, optional
        The number of joints the consumer expects. Checked against ``names``, and used to
        refuse a first message with another joint count while no order is configured.

    Raises
    ------
    ValueError
        If ``names`` is empty, holds duplicates or disagrees with ``n_joints``.
    """

    def __init__(self, names: Sequence[str] | None = None, *,
                 n_joints: int | None = None) -> None:
        self._n_joints = n_joints
        self._names: tuple[str, ...] | None = None
        self._index: dict[str, int] = {}
        # The message order seen last and its permutation: messages nearly always repeat it.
        self._last_names: tuple[str, ...] | None = None
        self._last_perm: NDArray[np.intp] = np.empty(0, dtype=np.intp)
        if names is not None:
            names = tuple(names)
            reason = self._check_new(names)
            if reason is not None:
                raise ValueError(f'joint names {list(names)} rejected: {reason.value}')
            self.adopt(names)

    @property
    def names(self) -> tuple[str, ...] | None:
        """The configured joint order, or None until one is configured or adopted."""
        return self._names

    @property
    def n_joints(self) -> int | None:
        """The number of joints, or None while neither configured nor adopted."""
        return self._n_joints if self._names is None else len(self._names)

    def adopt(self, names: Sequence[str]) -> None:
        """Configure the joint order as ``names`` (e.g. those of the first valid message).

        Raises
        ------
        ValueError
            If an order is configured already (the joint set never changes silently).
        """
        if self._names is not None:
            raise ValueError(f'joint order is configured already as {list(self._names)}')
        self._names = tuple(names)
        self._index = {name: i for i, name in enumerate(self._names)}

    def permutation(self, names: Sequence[str]) -> NDArray[np.intp] | SkipReason:
        """Return where each configured joint sits in a message, or why it cannot be mapped.

        Parameters
        ----------
        names : sequence of str
            The message's joint names, in message order.

        Returns
        -------
        perm : ndarray of shape (n_joints,) of intp, or SkipReason
            ``values[perm]`` puts a message array ``values`` in the configured order. While no
            order is configured, the identity if ``names`` is acceptable as the joint set
            (nothing is adopted: call :meth:`adopt` once the whole sample is known to be good).
            Otherwise ``DUPLICATE_JOINT``, ``UNKNOWN_JOINT``, ``MISSING_JOINT`` or
            ``JOINT_COUNT``, checked in that order.
        """
        key = names if isinstance(names, tuple) else tuple(names)
        if key == self._last_names:
            return self._last_perm
        if self._names is None:
            reason = self._check_new(key)
            return np.arange(len(key), dtype=np.intp) if reason is None else reason
        if len(set(key)) != len(key):
            return SkipReason.DUPLICATE_JOINT
        index = self._index
        if any(name not in index for name in key):
            return SkipReason.UNKNOWN_JOINT
        if len(key) != len(index):
            return SkipReason.MISSING_JOINT
        position = {name: i for i, name in enumerate(key)}
        perm = np.array([position[name] for name in self._names], dtype=np.intp)
        self._last_names, self._last_perm = key, perm
        return perm

    def _check_new(self, names: tuple[str, ...]) -> SkipReason | None:
        """Return why ``names`` cannot become the joint order, or None if it can."""
        if len(set(names)) != len(names):
            return SkipReason.DUPLICATE_JOINT
        if not names or (self._n_joints is not None and len(names) != self._n_joints):
            return SkipReason.JOINT_COUNT
        return None
