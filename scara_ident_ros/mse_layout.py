"""The layout of ``identification_mse`` (``std_msgs/Float64MultiArray``): encode and decode.

One message per publication, for n joints::

    data = [mse_1 .. mse_n, mse_total, nmse_1 .. nmse_n, nmse_total,
            vnmse_1 .. vnmse_n, vnmse_total]                         3(n + 1) floats
    layout.dim[0]: label 'metric:mse,nmse,validation_nmse', size 3, stride 3(n + 1)
    layout.dim[1]: label 'joint:<name_1>,...,<name_n>,total', size n + 1, stride n + 1

MSE in (N·m)² or N², NMSE without unit; the validation row is NaN until the identifier has
enough held-out samples. Runs recorded before the validation row have 2(n + 1) floats.
No rclpy here: the node turns :class:`Dimension` into ``MultiArrayDimension``.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from scara_ident_ros.identification.metrics import ErrorStats

__all__ = ['METRICS', 'METRICS_LABEL', 'Dimension', 'decode_mse', 'encode_mse']

#: The rows of the message, in order.
METRICS = ('mse', 'nmse', 'validation_nmse')
#: ``layout.dim[0].label``.
METRICS_LABEL = 'metric:' + ','.join(METRICS)


class Dimension(NamedTuple):
    """The fields of a ``std_msgs/MultiArrayDimension``."""

    label: str
    size: int
    stride: int


def encode_mse(names: Sequence[str], stats: ErrorStats, validation: ErrorStats | None
               ) -> tuple[list[Dimension], list[float]]:
    """Return ``(layout.dim, data)`` of one message (module docstring).

    Parameters
    ----------
    names : sequence of str
        The n joint names.
    stats : ErrorStats
        The windowed errors.
    validation : ErrorStats or None
        The errors on the held-out samples; None: not yet (NaN row).
    """
    n = len(names)
    dims = [Dimension(METRICS_LABEL, len(METRICS), len(METRICS) * (n + 1)),
            Dimension('joint:' + ','.join([*names, 'total']), n + 1, n + 1)]
    vnmse = ([*validation.nmse.tolist(), float(validation.nmse_total)]
             if validation is not None else [math.nan] * (n + 1))
    return dims, [*stats.mse.tolist(), float(stats.mse_total),
                  *stats.nmse.tolist(), float(stats.nmse_total), *vnmse]


def decode_mse(data: npt.ArrayLike, n_joints: int) -> dict[str, np.ndarray]:
    """Split messages' ``data`` into their metrics.

    Parameters
    ----------
    data : array_like of shape (..., 3(n + 1)) or (..., 2(n + 1))
        One message's data, or one per row.
    n_joints : int
        n.

    Returns
    -------
    dict of str to ndarray of shape (..., n + 1)
        Metric name (`METRICS`) to its values per joint, then the total; without
        ``'validation_nmse'`` for a message of two rows.

    Raises
    ------
    ValueError
        If the length is neither 2(n + 1) nor 3(n + 1).
    """
    values = np.asarray(data, dtype=np.float64)
    rows, extra = divmod(values.shape[-1], n_joints + 1)
    if extra or rows not in (2, 3):
        raise ValueError(f'identification_mse data of length {values.shape[-1]} is not 2 or 3 '
                         f'rows of {n_joints + 1}')
    split = values.reshape(*values.shape[:-1], rows, n_joints + 1)
    return {metric: split[..., i, :] for i, metric in enumerate(METRICS[:rows])}
