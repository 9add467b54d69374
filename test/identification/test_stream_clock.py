"""Lags against the stream's own clock: a replayed bag's stamps are not the wall clock."""
from __future__ import annotations

from scara_ident_ros.nodes.health import LossCounter
from scara_ident_ros.identification.stream_clock import (LAG_BINS, LagHistogram, PathDelays,
                                                         StreamClock)

MS = 1_000_000  # ns
NOW = 1_800_000_000_000_000_000  # ns, a wall clock
RECORDED = 1_600_000_000_000_000_000  # ns, the day a bag was recorded


def test_wall_clock_stamps_lag_by_wall_time() -> None:
    clock = StreamClock()
    clock.arrived(NOW - 2 * MS, NOW)
    assert clock.wall is True
    assert clock.lag_ns(NOW - 2 * MS, NOW + 8 * MS) == 10 * MS


def test_a_replayed_stream_lags_against_its_own_clock() -> None:
    """A bag recorded years ago, played at rate 1: the lag is the delay beyond the sample
    that came with the least delay, not years."""
    clock = StreamClock()
    for k in range(100):
        arrival = NOW + k * MS + (3 * MS if k % 10 == 0 else MS)  # 1 ms, now and then 3
        clock.arrived(RECORDED + k * MS, arrival)
    assert clock.wall is False
    assert clock.lag_ns(RECORDED + 99 * MS, NOW + 99 * MS + 11 * MS) == 10 * MS


def test_a_pause_starts_the_offset_anew() -> None:
    """After a gap between two recordings, the player's new offset holds (a smaller, old
    offset would make every later prediction look late)."""
    clock = StreamClock()
    clock.arrived(RECORDED, NOW)
    clock.arrived(RECORDED + 10**12, NOW + 5 * MS, restart=True)  # the next recording
    assert clock.lag_ns(RECORDED + 10**12, NOW + 15 * MS) == 10 * MS


def test_a_pause_is_counted_apart_from_lost_samples() -> None:
    """Recordings 0.5 s apart, replayed: the gaps are pauses, not 500 lost samples each;
    a few samples missing inside a recording are lost."""
    loss = LossCounter(span_s=0.02, pause_periods=5)
    stamp = RECORDED
    paused = []
    for recording in range(3):
        for k in range(1000):
            if recording == 1 and 500 <= k < 503:
                stamp += MS
                continue  # 3 samples lost on the way
            paused.append(loss.observe(stamp))
            stamp += MS
        stamp += 500 * MS
    assert loss.lost == 3
    assert loss.pauses == 2 and abs(loss.paused_s - 2 * 0.501) < 1e-9
    assert sum(paused) == 2 and paused[1000] and paused[1997]


def test_lag_percentiles_are_upper_bounds_of_1_ms_bins() -> None:
    lags = LagHistogram()
    assert lags.percentile_ms(99) is None
    for k in range(1000):
        lags.add((10 + (k % 10 == 0) * 40) * MS + 1)  # 90 % at 10 ms, 10 % at 50 ms
    assert lags.percentile_ms(50) == 11.0
    assert lags.percentile_ms(99) == 51.0
    lags.add(10**12)  # beyond the bins: counted in the last
    assert lags.percentile_ms(100) == LAG_BINS + 1


def test_the_path_delay_counts_each_predicted_sample_once() -> None:
    """From arrival to publication; a refused sample (never predicted) is let go."""
    path = PathDelays()
    for k in range(30):
        path.arrived(RECORDED + k * MS, NOW + k * MS)
    path.out(RECORDED, RECORDED + 9 * MS, NOW + 19 * MS)  # 10 predictions, 10-19 ms late
    path.out(RECORDED + 11 * MS, RECORDED + 11 * MS, NOW + 21 * MS)  # sample 10 never was
    assert path.delays.count == 11
    assert path.delays.percentile_ms(100) == 20.0
