"""Validation blocks for early stopping: whole blocks of consecutive samples, spread out.

Neighbouring samples of a recording are nearly identical, so a validation set of single
samples drawn at random would validate on copies of the training data and early stopping
would never see overfitting; the last part of a recording ends with another motion than the
rest. So the K blocks of a recording are cut into m = round(fraction·K) strata of
consecutive blocks and one block of each stratum validates (:func:`choose_blocks`).
``identification.split.block_split`` cuts blocks by time; :func:`row_split` cuts arrays
without stamps (``FeedForwardNet.fit``, ``HybridModel.fit``) into :data:`ROW_BLOCKS` blocks of
consecutive rows.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ['ROW_BLOCKS', 'VALIDATION_FRACTION', 'choose_blocks', 'row_split']

#: Defaults of ``scara-ident train``, ``tables`` and the models' ``fit``: a fifth of the
#: blocks validate.
VALIDATION_FRACTION = 0.2
#: Blocks of consecutive rows that :func:`row_split` cuts arrays without stamps into.
ROW_BLOCKS = 50

IntArray = npt.NDArray[np.int64]


def choose_blocks(present: npt.ArrayLike, fraction: float, seed: int) -> IntArray:
    """The validation blocks among K >= 2 blocks ``present`` (sorted block numbers).

    m = round(fraction·K) (at least 1, at most K − 1) validate: the K blocks are cut into m
    strata of consecutive blocks, as equal as can be, and one block of each, drawn with
    ``seed``, validates. Returns the m chosen block numbers.
    """
    blocks = np.asarray(present, dtype=np.int64)
    k = int(blocks.shape[0])
    m = min(max(1, round(fraction * k)), k - 1)
    edges = (np.arange(m + 1) * k) // m  # strata [edges[i], edges[i + 1]), none empty
    rng = np.random.default_rng(seed)
    return blocks[rng.integers(edges[:-1], edges[1:])]


def row_split(n_rows: int, fraction: float, *, seed: int = 0,
              n_blocks: int = ROW_BLOCKS) -> tuple[IntArray, IntArray]:
    """Training and validation rows of ``n_rows`` samples in time order, without stamps.

    The rows are cut into ``min(n_blocks, n_rows)`` blocks of consecutive rows, as equal as
    can be, and :func:`choose_blocks` picks the validation blocks. With ``fraction`` 0 or
    fewer than 2 rows, every row trains.

    Returns
    -------
    train, validation : ndarray of int64
        Row indices, in order.
    """
    if not 0.0 <= fraction < 1.0:
        raise ValueError(f'validation fraction must be in [0, 1), got {fraction}')
    rows = np.arange(n_rows, dtype=np.int64)
    if fraction == 0.0 or n_rows < 2:
        return rows, rows[:0]
    k = min(n_blocks, n_rows)
    block = (rows * k) // n_rows
    mask = np.isin(block, choose_blocks(np.arange(k), fraction, seed))
    return rows[~mask], rows[mask]
