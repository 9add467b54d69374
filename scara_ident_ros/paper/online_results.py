"""What the online identifiers of a run predicted, paired with what was measured.

During ``scara-ident run`` each identifier publishes, for every joint-state sample it used,
its a-priori prediction on ``/<method>/identified_torque`` (a ``JointState`` whose
``effort`` is the prediction and whose ``header.stamp`` is the input's stamp), and its
windowed errors on ``/<method>/identification_mse``. Pairing each prediction with the
``/joint_states`` message of the same stamp gives the measured and predicted efforts from
which the Table 3 analog and Figures 6–13 and 15 are made, independently of the numbers the
identifier computed itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from scara_ident_ros.identification.error_window import recent_errors
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.paper.table3 import DEFAULT_WINDOW, stream_data_names
from scara_ident_ros.paper.rows import ResultRow
from scara_ident_ros.identification import PAPER_WINDOW
from scara_ident_ros.identification.metrics import normalised_mse
from scara_ident_ros.nn.presets import method as method_spec
from scara_ident_ros.topics import mse_topic, torque_topic

if TYPE_CHECKING:
    from scara_ident_ros.identification.dataset import JointStateArrays

__all__ = ['STREAM_ALL', 'OnlinePredictions', 'mse_topic', 'pair_by_stamp', 'prediction_rows',
           'read_identifier_mse', 'read_online_predictions', 'rolling_errors', 'torque_topic']

#: ``data`` name of the rows over the whole run.
STREAM_ALL = 'stream-all'


@dataclass(frozen=True)
class OnlinePredictions:
    """A-priori predictions of one identifier paired with the measured efforts.

    Attributes
    ----------
    names : tuple of str of length n
        Joints, in column order.
    stamp_ns : ndarray of shape (K,) of int64
        Stamps of the paired samples (ns), increasing.
    measured, predicted : ndarray of shape (K, n)
        Measured effort and a-priori prediction (N·m or N).
    n_published, n_unmatched : int
        Predictions in the bag, and those without a ``/joint_states`` of the same stamp.
    """

    method: str
    names: tuple[str, ...]
    stamp_ns: NDArray[np.int64]
    measured: NDArray[np.float64]
    predicted: NDArray[np.float64]
    n_published: int
    n_unmatched: int

    @property
    def time_s(self) -> NDArray[np.float64]:
        """Seconds since the first paired sample, shape (K,)."""
        if self.stamp_ns.shape[0] == 0:
            return np.zeros(0)
        return (self.stamp_ns - self.stamp_ns[0]) * 1e-9


def pair_by_stamp(stamp_ns: NDArray[np.int64], pred_stamp_ns: NDArray[np.int64]
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Match predictions to measurements of the same stamp.

    ``stamp_ns`` (N,) and ``pred_stamp_ns`` (M,) are in any order (for a repeated stamp the
    first counts); return the indices ``i_meas``, ``i_pred`` (K,) of the matched pairs in
    increasing stamp order.
    """
    meas = np.asarray(stamp_ns, dtype=np.int64)
    pred = np.asarray(pred_stamp_ns, dtype=np.int64)
    meas_stamps, meas_first = np.unique(meas, return_index=True)
    pred_stamps, pred_first = np.unique(pred, return_index=True)
    _, in_meas, in_pred = np.intersect1d(meas_stamps, pred_stamps, assume_unique=True,
                                         return_indices=True)
    return meas_first[in_meas].astype(np.intp), pred_first[in_pred].astype(np.intp)


def rolling_errors(measured: NDArray[np.float64], predicted: NDArray[np.float64],
                   window: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Windowed MSE and NMSE at every sample, averaged over the joints.

    At sample k the window holds samples max(0, k − window + 1) .. k (fewer at the start),
    as the identifier's error window does.

    Parameters
    ----------
    measured, predicted : ndarray of shape (N, n)
        Measured and predicted efforts (N·m or N).
    window : int
        Samples per window, >= 1.

    Returns
    -------
    mse : ndarray of shape (N,)
        Mean over joints of each joint's windowed MSE ((N·m)², N²; mixes units as the
        paper's figures do).
    nmse : ndarray of shape (N,)
        Mean over the joints of MSE / effort variance in the window, where defined
        (:func:`~scara_ident_ros.identification.metrics.normalised_mse`); NaN where
        it is for no joint.
    """
    y = np.asarray(measured, dtype=np.float64)
    y_hat = np.asarray(predicted, dtype=np.float64)
    if y.ndim != 2 or y.shape != y_hat.shape:
        raise ValueError(f'measured and predicted must have the same shape (N, n), got '
                         f'{y.shape} and {y_hat.shape}')
    if window < 1:
        raise ValueError(f'window must be >= 1, got {window}')
    count = y.shape[0]
    if count == 0:
        return np.zeros(0), np.zeros(0)
    centred = y - y.mean(axis=0)  # moments about the mean: no catastrophic cancellation
    stacked = np.concatenate([(y - y_hat) ** 2, centred, centred ** 2], axis=1)
    sums = np.cumsum(np.vstack([np.zeros((1, stacked.shape[1])), stacked]), axis=0)
    stop = np.arange(1, count + 1)
    start = np.maximum(stop - window, 0)
    size = (stop - start)[:, None].astype(np.float64)
    means = (sums[stop] - sums[start]) / size
    n = y.shape[1]
    mse, mean, mean_square = means[:, :n], means[:, n:2 * n], means[:, 2 * n:]
    # the cumulative sums' rounding is relative to the whole run's spread, not the window's
    _, nmse = normalised_mse(mse, np.maximum(mean_square - mean ** 2, 0.0),
                             np.abs(centred).max(axis=0) ** 2)
    return mse.mean(axis=1), nmse


def prediction_rows(predictions: OnlinePredictions, *, window: int = DEFAULT_WINDOW,
                    paper_window: int = PAPER_WINDOW) -> list[ResultRow]:
    """The Table 3 analog's rows of one identifier: errors of its a-priori predictions.

    Named like :func:`scara_ident_ros.paper.table3.online_rows`: over the last
    ``paper_window`` samples (the paper's "error over the last 100 samples", computed by
    ``ErrorWindow.recent``), the last ``window`` samples, and :data:`STREAM_ALL`, the whole
    run. ``iterations`` is the number of paired samples, ``seed`` None (one run).
    """
    label = method_spec(predictions.method).label
    y, y_hat = predictions.measured, predictions.predicted
    extra = dict(iterations=int(y.shape[0]), note=f'{predictions.n_published} published, '
                                                   f'{predictions.n_unmatched} unmatched')
    short, long = stream_data_names(window, paper_window)
    return [ResultRow.from_stats(stats, table='online', method=label, seed=None, data=data,
                                 **extra)
            for data, stats in ((short, recent_errors(y, y_hat, paper_window)),
                                (long, effort_errors(y[-window:], y_hat[-window:])),
                                (STREAM_ALL, effort_errors(y, y_hat)))]


def read_online_predictions(bag: Path, method: str,
                            measured: JointStateArrays) -> OnlinePredictions | None:
    """Read ``method``'s predictions from a run bag and pair them with ``measured``.

    The predictions come from :func:`torque_topic` and are mapped to the joints of
    ``measured`` (the bag's ``/joint_states``) by name; None if the bag has no such topic.
    """
    from scara_ident_ros.bag import open_bag, read_joint_states
    from scara_ident_ros.bag.recording_file import is_rosbag2

    topic = torque_topic(method)
    if not is_rosbag2(bag):  # a table or a ROS 1 bag: joint states only
        return None
    with open_bag(bag) as reader:
        if topic not in reader.topics:
            return None
    series = read_joint_states(bag, topic=topic, joints=list(measured.names))
    i_meas, i_pred = pair_by_stamp(measured.stamp_ns, series.stamp_ns)
    effort = np.asarray(measured.effort, dtype=np.float64)
    predicted = np.asarray(series.effort, dtype=np.float64)
    good = (np.isfinite(effort[i_meas]).all(axis=1)
            & np.isfinite(predicted[i_pred]).all(axis=1))
    i_meas, i_pred = i_meas[good], i_pred[good]
    n_published = int(series.stamp_ns.shape[0])
    return OnlinePredictions(
        method=method, names=tuple(measured.names),
        stamp_ns=np.asarray(measured.stamp_ns, dtype=np.int64)[i_meas],
        measured=effort[i_meas], predicted=predicted[i_pred], n_published=n_published,
        n_unmatched=n_published - int(i_pred.shape[0]))


def read_identifier_mse(bag: Path, method: str
                        ) -> tuple[NDArray[np.int64], NDArray[np.float64]] | None:
    """Read the windowed errors ``method``'s identifier published during the run.

    Returns
    -------
    (log_time_ns, data) or None
        Receive times (M,) in ns and the messages' ``data`` (M, 3(n + 1)), laid out as
        :mod:`scara_ident_ros.mse_layout` says (``decode_mse`` splits it); None if the bag
        has no such topic, no message, or messages other than ``std_msgs/Float64MultiArray``.
    """
    from rosbags.typesys import Stores, get_typestore
    from rosbags.typesys.stores.ros2_jazzy import (
        std_msgs__msg__Float64MultiArray as Float64MultiArray)

    from scara_ident_ros.bag import open_bag
    from scara_ident_ros.bag.recording_file import is_rosbag2

    if not is_rosbag2(bag):  # a table or a ROS 1 bag: joint states only
        return None
    topic = mse_topic(method)
    store = get_typestore(Stores.ROS2_JAZZY)
    times: list[int] = []
    rows: list[NDArray[np.float64]] = []
    with open_bag(bag) as reader:
        if topic not in reader.topics:
            return None
        for _, msgtype, log_time_ns, raw in reader.messages([topic]):
            msg = store.deserialize_cdr(raw, msgtype)
            if not isinstance(msg, Float64MultiArray):
                return None
            times.append(int(log_time_ns))
            rows.append(np.asarray(msg.data, dtype=np.float64))
    if not rows or len({row.shape for row in rows}) != 1:
        return None
    return np.array(times, dtype=np.int64), np.vstack(rows)
