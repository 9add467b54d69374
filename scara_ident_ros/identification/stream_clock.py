"""How late a prediction is, against the stream's own clock when that is not the wall clock.

With wall-clock stamps a prediction's lag is its publication time minus its sample's stamp.
A replayed bag or simulated time has an arbitrary offset from the wall clock; there the
offset is the smallest ``arrival − stamp`` seen (the least-delayed sample counts as on
time), and the lag is ``publication − stamp − offset``. A pause starts the offset anew.
"""
from __future__ import annotations

from collections import deque

__all__ = ['LAG_BINS', 'LagHistogram', 'PathDelays', 'StreamClock', 'WALL_TOLERANCE_NS']

#: Stamps within this of the wall clock (ns) are taken as wall-clock stamps: a minute
#: covers clocks synchronised between machines and any realistic delay.
WALL_TOLERANCE_NS = 60_000_000_000
LAG_BINS = 10_000  # 1 ms bins of LagHistogram: 10 s


class StreamClock:
    """The offset between the wall clock and the stream's stamps, for lags.

    Attributes
    ----------
    wall : bool or None
        Whether the stamps are wall-clock stamps; None before the first sample.
    """

    def __init__(self) -> None:
        self.wall: bool | None = None
        self._offset_ns: int | None = None

    def arrived(self, stamp_ns: int, now_ns: int, *, restart: bool = False) -> None:
        """Take a sample stamped ``stamp_ns`` that arrived at wall time ``now_ns`` (both
        ns); ``restart``: it follows a pause or a restarted clock."""
        delay = now_ns - stamp_ns
        self.wall = abs(delay) < WALL_TOLERANCE_NS
        if self.wall:
            self._offset_ns = 0
        elif restart or self._offset_ns is None or delay < self._offset_ns:
            self._offset_ns = delay

    def lag_ns(self, stamp_ns: int, now_ns: int) -> int:
        """How late (ns) something about the sample stamped ``stamp_ns`` is at ``now_ns``."""
        return now_ns - stamp_ns - (self._offset_ns or 0)


class LagHistogram:
    """Lags counted in 1 ms bins up to :data:`LAG_BINS` ms (longer ones in the last), for
    percentiles over a whole run at the cost of one integer division per prediction."""

    def __init__(self) -> None:
        self._counts = [0] * (LAG_BINS + 1)
        self.count = 0

    def add(self, lag_ns: int) -> None:
        """Count one lag (ns; a negative one as 0)."""
        self._counts[min(max(lag_ns, 0) // 1_000_000, LAG_BINS)] += 1
        self.count += 1

    def percentile_ms(self, q: float) -> float | None:
        """The ``q`` percentile (0-100) in ms, as the upper edge of its 1 ms bin (an upper
        bound); None before any lag."""
        if not self.count:
            return None
        rank = q / 100.0 * self.count
        total = 0
        for index, n in enumerate(self._counts):
            total += n
            if total >= rank and n:
                return float(index + 1)
        return float(LAG_BINS + 1)


class PathDelays:
    """The message path's own delay: from a sample's arrival to its prediction's
    publication, whatever the stream's clock (it includes the q'' estimate's wait for the
    samples after it).

    ``keep`` arrivals are kept until their prediction is out (refused samples fall out of
    the oldest end).
    """

    def __init__(self, keep: int = 1000) -> None:
        self._arrivals: deque[tuple[int, int]] = deque(maxlen=keep)  # (stamp, wall) ns
        self.delays = LagHistogram()

    def arrived(self, stamp_ns: int, now_ns: int) -> None:
        """A sample stamped ``stamp_ns`` arrived at wall time ``now_ns`` (ns)."""
        self._arrivals.append((stamp_ns, now_ns))

    def out(self, first_ns: int, last_ns: int, now_ns: int) -> None:
        """The predictions of the samples stamped ``first_ns`` to ``last_ns`` are out at
        ``now_ns``: count their delays."""
        arrivals = self._arrivals
        while arrivals and arrivals[0][0] <= last_ns:
            stamp, arrived = arrivals.popleft()
            if stamp >= first_ns:
                self.delays.add(now_ns - arrived)
