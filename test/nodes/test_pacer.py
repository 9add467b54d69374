"""DeadlinePacer: absolute deadlines, catch-up and late counts, with a fake clock."""
from __future__ import annotations

import pytest

from scara_ident_ros.nodes.pacer import DeadlinePacer

MS = 1_000_000


class FakeTime:
    def __init__(self) -> None:
        self.now = 0
        self.slept: list[float] = []

    def clock(self) -> int:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.now += round(seconds * 1e9)


def make(rtf: float = 1.0) -> tuple[DeadlinePacer, FakeTime]:
    fake = FakeTime()
    return DeadlinePacer(MS, real_time_factor=rtf, clock=fake.clock, sleep=fake.sleep), fake


def test_one_sample_per_period_without_drift() -> None:
    pacer, fake = make()
    total = 0
    for _ in range(1000):
        total += pacer.wait(1.0)
        fake.now += 300_000  # work takes 0.3 ms: must not accumulate
    assert total == 1000
    assert pacer.deadline_ns(999) == 999 * MS
    assert fake.now == pytest.approx(999 * MS + 300_000)
    assert pacer.late == 0


def test_catches_up_after_a_stall_and_counts_late_samples() -> None:
    pacer, fake = make()
    assert pacer.wait(1.0) == 1  # sample 0 at t=0
    fake.now = 10 * MS + 1  # stalled for 10 ms
    due = pacer.wait(1.0)
    assert due == 10  # samples 1..10 are due now
    assert pacer.late == 9  # samples 1..9 are more than a period overdue
    assert pacer.issued == 11


def test_wait_bounded_by_max_wait() -> None:
    pacer, fake = make(rtf=0.001)  # one sample per second of wall time
    assert pacer.wait(1.0) == 1
    assert pacer.wait(0.1) == 0
    assert fake.slept[-1] == pytest.approx(0.1)


def test_as_fast_as_possible_issues_bursts() -> None:
    pacer, fake = make(rtf=0.0)
    assert pacer.wait(1.0) == 100
    assert fake.slept == []


@pytest.mark.parametrize('period, rtf', [(0, 1.0), (MS, -1.0)])
def test_rejects_bad_settings(period: int, rtf: float) -> None:
    with pytest.raises(ValueError):
        DeadlinePacer(period, real_time_factor=rtf)
