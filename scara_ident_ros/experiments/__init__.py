"""The paper's comparison, reproduced on plain arrays: Table 2 and 3 analogs, LS reference.

Pure numpy (no rclpy). ``scara-ident compare`` feeds these functions with simulated data,
``scara-ident tables`` with recorded bags; both produce the same rows and tables.

Modules, one concept each:

``datasets``         X = [q, q', q''], Y = efforts, stamps; from the simulator or any arrays
``rows``             `ResultRow` (one model on one data set), `summarise` over seeds
``hyperparameters``  the per-method grid search of online-learning settings
``metrics``          MSE and normalised MSE (MSE / effort variance) per joint
``table2``           Table 2 analog: LM training from several seeds
``table3``           Table 3 analog: per-sample learning over a stream
``reference``        the model-based least-squares row
``tables``           rows to Markdown and CSV, the paper's numbers beside ours
"""
from __future__ import annotations

from scara_ident_ros.experiments.datasets import (ACCELERATIONS, Dataset, Evaluations,
                                                  dataset_from_record,
                                                  make_dataset, simulate_dataset,
                                                  simulate_record)
from scara_ident_ros.experiments.hyperparameters import (DEFAULT_GRID, QUICK_GRID, Grid,
                                                         Hyperparameters, Scaling,
                                                         SearchResult, Trial, best_of,
                                                         search)
from scara_ident_ros.identification.error_window import recent_errors
from scara_ident_ros.identification.metrics import effort_errors
from scara_ident_ros.experiments.table2 import (DEFAULT_GOAL, OfflineFit, OfflineRuns,
                                                 fit_offline, goal_iteration, offline_rows,
                                                 run_offline, train_offline)
from scara_ident_ros.experiments.table3 import (DEFAULT_WINDOW, OnlineTrace, hold_rows,
                                                learn_online, online_rows, run_online,
                                                stream_data_names)
from scara_ident_ros.experiments.reference import (ReferenceFit, fit_reference,
                                                   online_reference_rows, predict_reference,
                                                   reference_rows)
from scara_ident_ros.experiments.rows import (HOLD, REFERENCE, ResultRow, Spread, Summary,
                                               summarise)
from scara_ident_ros.experiments.tables import (PAPER_ITERATIONS, PAPER_NOTE, PAPER_SAMPLES,
                                                PAPER_TABLE2, PAPER_TABLE3, format_spread,
                                                format_value, joint_markdown,
                                                offline_markdown, online_markdown,
                                                paper_ranking, ranking, ranking_text, read_csv,
                                                write_csv)

__all__ = [
    'ACCELERATIONS', 'DEFAULT_GOAL', 'DEFAULT_GRID', 'DEFAULT_WINDOW', 'Dataset',
    'Evaluations', 'Grid', 'HOLD', 'Hyperparameters', 'OfflineFit', 'OfflineRuns', 'OnlineTrace',
    'PAPER_ITERATIONS', 'PAPER_NOTE', 'PAPER_SAMPLES', 'PAPER_TABLE2', 'PAPER_TABLE3',
    'QUICK_GRID', 'REFERENCE', 'ReferenceFit', 'ResultRow', 'Scaling', 'SearchResult',
    'Spread', 'Summary', 'Trial', 'best_of', 'dataset_from_record',
    'effort_errors', 'fit_offline', 'fit_reference', 'format_spread',
    'format_value', 'goal_iteration', 'hold_rows', 'joint_markdown', 'learn_online',
    'make_dataset', 'offline_markdown', 'offline_rows', 'online_markdown',
    'online_reference_rows', 'online_rows', 'paper_ranking', 'predict_reference', 'ranking',
    'ranking_text', 'read_csv', 'recent_errors', 'reference_rows', 'run_offline', 'run_online',
    'search', 'simulate_dataset', 'simulate_record', 'stream_data_names', 'summarise',
    'train_offline', 'write_csv',
]
