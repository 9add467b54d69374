"""Offline work on recorded runs: retraining from bags, evaluation, the paper's tables and figures.

What ``scara-ident train``, ``evaluate`` and ``tables`` are made of, one concept per module:

============================  ==========================================================
``dataset``                   joint states → network samples as the identifier makes them;
                              time split
``recording``                 a bag read into samples, or one clear error
``evaluation``                model files checked against recordings; error tables
``online_results``            identifiers' published predictions paired with measurements
``retraining``                the Table 2 analog: methods × seeds, Levenberg–Marquardt
``figures``                   Figures 6–15 as PNG files
``report``                    ``make_report``: everything into ``DIR/report.md``
``comparison``                ``scara-ident compare``: the same tables on simulated data
``progress``                  a text progress bar for ``fit``
============================  ==========================================================

The numerical core (samples, pairing, windowed errors) is plain numpy; reading bags goes
through :mod:`scara_ident_ros.bag`, nothing here imports rclpy.
"""
from __future__ import annotations

from scara_ident_ros.offline.dataset import (JointStateArrays, RecordedDataset,
                                             dataset_from_joint_states, time_split)
from scara_ident_ros.offline.evaluation import (ModelMismatch, errors_markdown, evaluate,
                                                load_model, model_joint_names, model_method)
from scara_ident_ros.offline.online_results import (OnlinePredictions, pair_by_stamp,
                                                    prediction_rows, read_identifier_mse,
                                                    read_online_predictions, rolling_errors)
from scara_ident_ros.offline.recording import (MIN_SAMPLES, Recording, RecordingError,
                                               load_recording)
from scara_ident_ros.offline.report import make_report
from scara_ident_ros.offline.retraining import Retraining, retrain
from scara_ident_ros.offline.split import block_split

__all__ = [
    'JointStateArrays', 'MIN_SAMPLES', 'ModelMismatch', 'OnlinePredictions', 'RecordedDataset',
    'Recording', 'RecordingError', 'Retraining', 'block_split', 'dataset_from_joint_states',
    'errors_markdown',
    'evaluate', 'load_model', 'load_recording', 'make_report', 'model_joint_names',
    'model_method', 'pair_by_stamp', 'prediction_rows', 'read_identifier_mse',
    'read_online_predictions', 'retrain', 'rolling_errors', 'time_split',
]
