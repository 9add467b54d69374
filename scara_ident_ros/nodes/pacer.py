"""Real-time pacing against absolute deadlines (no drift, catch-up counted)."""
from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ['DeadlinePacer']


class DeadlinePacer:
    """Issue samples on absolute deadlines ``t0 + k·period / real_time_factor``.

    Deadlines never drift: sample k is due at a fixed time from the start, whatever
    the delays before it. A loop that fell behind gets every overdue sample at once
    and catches up; samples issued more than one period after their deadline are
    counted in :attr:`late`.

    Parameters
    ----------
    period_ns : int
        Sample period in (simulated) nanoseconds, > 0.
    real_time_factor : float
        Simulated seconds per wall-clock second; 0: as fast as possible, ``burst`` samples
        per call.
    clock, sleep : callable, optional
        Monotonic clock (ns) and sleep (s).
    """

    def __init__(self, period_ns: int, *, real_time_factor: float = 1.0,
                 clock: Callable[[], int] = time.monotonic_ns,
                 sleep: Callable[[float], None] = time.sleep, burst: int = 100) -> None:
        if period_ns <= 0:
            raise ValueError(f'period_ns must be > 0, got {period_ns}')
        if real_time_factor < 0:
            raise ValueError(f'real_time_factor must be >= 0, got {real_time_factor}')
        self._wall_period = 0.0 if real_time_factor == 0 else period_ns / real_time_factor
        self._clock = clock
        self._sleep = sleep
        self._burst = burst
        self._t0 = clock()
        self.issued = 0  #: samples handed out so far
        self.late = 0  #: samples handed out more than one period after their deadline

    def restart(self) -> None:
        """Put the first deadline (sample 0) at the current time."""
        self._t0 = self._clock()
        self.issued = 0
        self.late = 0

    def deadline_ns(self, k: int) -> int:
        """Wall-clock deadline of sample ``k`` in ns of the pacer's clock."""
        return self._t0 + round(k * self._wall_period)

    def wait(self, max_wait_s: float) -> int:
        """Sleep until the next deadline (at most ``max_wait_s``); return how many samples
        are due now (0 if the wait ran out, more than 1 while catching up), now issued."""
        if self._wall_period == 0:
            self.issued += self._burst
            return self._burst
        remaining = self.deadline_ns(self.issued) - self._clock()
        if remaining > 0:
            if remaining > max_wait_s * 1e9:
                self._sleep(max_wait_s)
                return 0
            self._sleep(remaining / 1e9)
        now = self._clock()
        due = int((now - self._t0) // self._wall_period) + 1 - self.issued
        if due <= 0:
            return 0
        # Samples whose deadline is more than one period past are late.
        on_time_from = int((now - self._t0 - self._wall_period) // self._wall_period) + 1
        self.late += max(0, min(due, on_time_from - self.issued))
        self.issued += due
        return due
