"""``scara-ident lag``'s figures: percentiles after the start-up, the slow samples in time."""
from __future__ import annotations

import numpy as np
import pytest

from scara_ident_ros.cli.lag import lag_figures

MS = 1_000_000  # ns


def test_the_figures_leave_out_the_start_and_find_the_window_of_the_slow_samples() -> None:
    n = 20_000  # 20 s at 1 kHz
    stamps = np.arange(n, dtype=np.int64) * MS
    lag = np.full(n, 2 * MS)
    lag[:500] = 900 * MS  # start-up: left out
    lag[12_000:12_150] = 120 * MS  # a stall of 150 samples in 10-15 s
    lag[17_000] = 300 * MS
    figures = lag_figures('/joint_states', stamps, stamps + lag, skip_s=1.0, window_s=5.0)
    assert figures.received == n
    # the first second of receipts, from the first (900 ms late): up to sample 1,898
    assert figures.counted == n - 1898
    assert figures.p50_ms == pytest.approx(2.0)
    assert figures.p99_ms == pytest.approx(2.0)
    assert figures.p999_ms == pytest.approx(120.0)
    assert figures.max_ms == pytest.approx(300.0)
    # windows from the first receipt (which came 900 ms late)
    assert sum(figures.above_p99) == 151
    start, count, top = figures.worst[0]
    assert (count, top) == (150, pytest.approx(120.0))
    assert start <= (12_000 + 2) / 1000 - 0.9 < start + 5.0


def test_no_message_gives_no_figure() -> None:
    empty = np.zeros(0, np.int64)
    figures = lag_figures('/x', empty, empty)
    assert figures.received == 0 and np.isnan(figures.p99_ms) and figures.worst == []
