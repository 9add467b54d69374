"""Validation blocks spread over the recording: every sample once, whole blocks, seeded."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.identification.dataset import Dataset
from scara_ident_ros.identification.split import (SplitError, alternate_blocks, block_index,
                                                  block_split, later_split)

START_NS = 1_700_000_000_000_000_000


def _samples(seconds: float, *, rate_hz: float = 1000.0, pause_s: tuple[float, float] = (0, 0),
             n: int = 2) -> Dataset:
    """``seconds`` of samples at ``rate_hz``, none stamped within ``pause_s`` (start, end)."""
    t = np.arange(round(seconds * rate_hz)) / rate_hz
    t = t[(t < pause_s[0]) | (t >= pause_s[1])]
    X = np.repeat(t[:, None], 3 * n, axis=1)  # the time in every column: easy to trace
    return Dataset(START_NS + np.round(t * 1e9).astype(np.int64), X, X[:, :n].copy())


def test_every_sample_once_in_time_order() -> None:
    data = _samples(20.0)
    train, val = block_split(data, 0.2)
    assert len(train) + len(val) == len(data)
    both = np.sort(np.concatenate([train.stamp_ns, val.stamp_ns]))
    np.testing.assert_array_equal(both, data.stamp_ns)
    assert np.all(np.diff(train.stamp_ns) > 0) and np.all(np.diff(val.stamp_ns) > 0)
    np.testing.assert_allclose(val.X[:, 0], (val.stamp_ns - START_NS) * 1e-9)  # rows kept
    assert (train.name, val.name) == ('train', 'validation')


def test_validation_is_whole_blocks_one_per_stratum() -> None:
    data = _samples(60.0)  # 60 blocks of 1 s, 1000 samples each
    train, val = block_split(data, 0.2, block_s=1.0, seed=3)
    blocks = block_index(val.stamp_ns, block_s=1.0, start_ns=START_NS)
    chosen, counts = np.unique(blocks, return_counts=True)
    assert chosen.tolist() == sorted(set(chosen.tolist())) and np.all(counts == 1000)  # whole
    assert len(chosen) == 12  # 20 % of 60 blocks
    np.testing.assert_array_equal(chosen // 5, np.arange(12))  # one in each 5 blocks
    assert not np.isin(block_index(train.stamp_ns, block_s=1.0, start_ns=START_NS),
                       chosen).any()
    # spread over the whole recording, not its end (what time_split would give)
    assert chosen[0] < 5 and chosen[-1] >= 55


@pytest.mark.parametrize('fraction', [0.05, 0.1, 0.2, 0.3, 0.5, 0.9])
@pytest.mark.parametrize('seconds', [2.5, 7.0, 33.3, 80.0])
def test_fraction_is_kept_within_one_block(fraction: float, seconds: float) -> None:
    data = _samples(seconds, rate_hz=200.0)
    blocks = int(np.ceil(seconds))
    _, val = block_split(data, fraction, block_s=1.0)
    chosen = np.unique(block_index(val.stamp_ns, block_s=1.0, start_ns=START_NS))
    assert 1 <= len(chosen) <= blocks - 1
    assert abs(len(chosen) - fraction * blocks) <= 1
    assert abs(len(val) - fraction * len(data)) <= 200  # one block of samples


def test_block_length_is_an_option() -> None:
    data = _samples(10.0)
    _, val = block_split(data, 0.2, block_s=0.25)
    chosen, counts = np.unique(block_index(val.stamp_ns, block_s=0.25, start_ns=START_NS),
                               return_counts=True)
    assert len(chosen) == 8 and np.all(counts == 250)


def test_the_seed_draws_the_blocks() -> None:
    data = _samples(40.0, rate_hz=100.0)
    first = block_split(data, 0.25, seed=7)[1].stamp_ns
    np.testing.assert_array_equal(block_split(data, 0.25, seed=7)[1].stamp_ns, first)
    others = [block_split(data, 0.25, seed=seed)[1].stamp_ns for seed in range(5)]
    assert len({tuple(stamps.tolist()) for stamps in others}) > 1


def test_pauses_are_no_blocks() -> None:
    data = _samples(20.0, pause_s=(5.0, 15.0))  # 10 s with samples, then 10 s without
    _, val = block_split(data, 0.2)
    chosen = np.unique(block_index(val.stamp_ns, block_s=1.0, start_ns=START_NS))
    assert len(chosen) == 2 and len(val) == 2000  # 20 % of the 10 blocks that have samples
    assert chosen[0] < 5 <= 15 <= chosen[1]  # one before the pause, one after


def test_no_fraction_no_validation_and_bad_input() -> None:
    data = _samples(3.0)
    train, val = block_split(data, 0.0)
    assert len(train) == len(data) and len(val) == 0 and val.X.shape == (0, 6)
    empty = data.take(slice(0, 0))
    assert [len(part) for part in block_split(empty, 0.2)] == [0, 0]
    with pytest.raises(ValueError, match='validation fraction'):
        block_split(data, 1.0)
    with pytest.raises(ValueError, match='block length'):
        block_split(data, 0.2, block_s=0.0)
    with pytest.raises(ValueError, match=r'fill 1 block of 5 s; .* at least 2'):
        block_split(data, 0.2, block_s=5.0)


def test_alternate_blocks_deal_the_validation_blocks_in_two() -> None:
    data = _samples(20.0)
    _, validation = block_split(data, 0.3, block_s=1.0, seed=4)
    start = int(data.stamp_ns[0])
    first, second = alternate_blocks(validation, block_s=1.0, start_ns=start)
    blocks = np.unique(block_index(validation.stamp_ns, block_s=1.0, start_ns=start))
    assert len(blocks) == 6
    np.testing.assert_array_equal(
        np.unique(block_index(first.stamp_ns, block_s=1.0, start_ns=start)), blocks[0::2])
    np.testing.assert_array_equal(
        np.unique(block_index(second.stamp_ns, block_s=1.0, start_ns=start)), blocks[1::2])
    assert len(first) + len(second) == len(validation)
    one, none = alternate_blocks(validation.take(slice(0, 10)), block_s=1.0, start_ns=start)
    assert len(one) == 10 and len(none) == 0


def _series(seconds: float, rate_hz: float = 100.0, n: int = 2) -> Dataset:
    stamps = np.arange(round(seconds * rate_hz), dtype=np.int64) * round(1e9 / rate_hz)
    rows = stamps.shape[0]
    return Dataset(stamps, np.arange(rows * 3 * n, dtype=float).reshape(rows, 3 * n),
                   np.arange(rows * n, dtype=float).reshape(rows, n))


def test_later_motion_is_the_end_of_the_recording_and_in_no_other_part() -> None:
    data = _series(10.0)  # 1000 samples, 0 to 9.99 s
    earlier, later = later_split(data, 0.3)
    assert earlier.name == 'earlier' and later.name == 'later'
    assert len(earlier) + len(later) == len(data)
    assert not np.intersect1d(earlier.stamp_ns, later.stamp_ns).size
    assert earlier.stamp_ns.max() < later.stamp_ns.min()  # every later sample comes after
    assert later.seconds == pytest.approx(0.3 * data.seconds, abs=0.011)


def test_with_several_recordings_the_last_is_held_out_whole() -> None:
    data = _series(6.0)
    labels = np.repeat([0, 1, 2], 200)
    earlier, later = later_split(data, 0.3, recording=labels)
    np.testing.assert_array_equal(later.stamp_ns, data.stamp_ns[400:])
    np.testing.assert_array_equal(earlier.stamp_ns, data.stamp_ns[:400])
    with pytest.raises(ValueError, match='label per sample'):
        later_split(data, 0.3, recording=labels[:10])


def test_a_later_split_that_leaves_a_part_empty_is_refused() -> None:
    with pytest.raises(ValueError, match=r'in \(0, 1\)'):
        later_split(_series(1.0), 1.0)
    with pytest.raises(SplitError, match='need at least 2'):
        later_split(_series(0.03), 0.01)
