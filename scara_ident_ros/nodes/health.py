"""Is a node doing its job? Levels, messages and figures for ``/diagnostics``, without ROS.

Each node reports once a second (converted in :mod:`scara_ident_ros.nodes.diagnostics`) a
:class:`Health`: a level, one line saying what is wrong and what to do, and its figures.
The rules and their thresholds are in the functions below and in the messages they write;
the nodes (and the tests) pass counters and times in.
"""
from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import IntEnum

__all__ = ['LATE_WARN', 'NMSE_WARN', 'RATE_ERROR', 'SKIPPED_WARN', 'STALE_AFTER',
           'STALL_AFTER', 'Deltas',
           'Health', 'Level', 'LossCounter', 'identifier_health', 'recorder_health',
           'simulator_health']

STALE_AFTER = 1.0  # s without a sample before the identifier warns
SKIPPED_WARN = 0.1  # fraction of a period's samples skipped before the identifier warns
NMSE_WARN = 1.0  # validation NMSE above which the model is worse than the mean
STALL_AFTER = 10.0  # s a learner process's due update may wait before the identifier warns
LATE_WARN = 0.01  # fraction of a period's samples late before the simulator warns
RATE_ERROR = 0.5  # fraction of the nominal rate below which the simulator is in error
LOST_GAP = 1.5  # stamp gap, in sample periods, from which samples count as lost
LOST_SPAN = 1.0  # s: a longer stamp jump is a restart of the stream, not lost samples
JITTER_MADS = 6.0  # robust standard deviations of the stamp differences that are jitter
PERIOD_SAMPLES = 64  # stamp differences whose median is the stream's period
LOSS_HORIZON = 100  # steps after a long one within which late samples may catch up
QUIET_MADS = 3.0  # robust standard deviations by which a step is short when catching up
QUIET_PERIODS = 0.25  # ... and at least this fraction of a period
MEAN_STEPS = 1000  # steps averaged (exponentially) into the period that lateness is measured by


class Level(IntEnum):
    """Severity, with the values of ``diagnostic_msgs/DiagnosticStatus`` (OK=0 ... STALE=3)."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclass(frozen=True)
class Health:
    """One node's state: the worst level found, the problems ('; '-separated, each with its
    threshold) or a one-line summary, and the formatted figures by name."""

    level: Level
    message: str
    values: dict[str, str] = field(default_factory=dict)


class Deltas:
    """How much cumulative counters grew since the previous call; a counter that went down
    was restarted (``~/reset``) and its growth is its value."""

    def __init__(self) -> None:
        self._last: dict[str, float] = {}

    def __call__(self, **counters: float) -> dict[str, float]:
        """Return each counter's growth since the previous call, by name."""
        last = self._last
        grown = {name: value - last.get(name, 0) if value >= last.get(name, 0) else value
                 for name, value in counters.items()}
        self._last = counters
        return grown


class LossCounter:
    """Samples missing from a periodic stream, estimated from its stamps.

    The period is the median of the latest :data:`PERIOD_SAMPLES` stamp differences, the
    jitter ``JITTER_MADS`` scaled median absolute deviations of them; a difference ``dt``
    longer than ``LOST_GAP`` periods and than one period plus the jitter, and at most
    ``span_s``, may hide ``round(dt / period) - 1`` lost samples. Whether it does shows in
    the stamps after it: samples that were merely late (uneven stamps, e.g. 0.7-8.8 ms steps
    at a nominal 1 kHz) are followed by short steps that bring the stream back on its
    schedule; lost ones leave it behind. So a long step's samples are counted ``lost`` when
    the stream is back on schedule (none) or after :data:`LOSS_HORIZON` more steps (the
    periods it is still behind). Behind is the long step's excess over the period less what
    the steps short by more than :data:`QUIET_MADS` jitters (measured before the long step:
    catching up widens them) and :data:`QUIET_PERIODS` periods caught up (and are left out
    of the period's median); other steps count nothing. Behind is measured in periods of
    the mean step (over about :data:`MEAN_STEPS`, neither long nor catching up): a median
    of 64 steps off by 1-2 % would make 26 catching-up steps look like a lost sample. ``lost`` only
    grows; :meth:`settle` counts what is pending at the end of a stream. Longer jumps (a
    replayed bag's gap, a simulator restart) count as ``pauses``, and only if also longer
    than ``pause_periods`` periods. Stamps repeated or going back count nothing. A recorder
    passes a long ``span_s`` (a network partition is loss); an identifier passes its
    ``max_gap`` (its q'' estimate restarts there).
    """

    def __init__(self, *, span_s: float = LOST_SPAN, pause_periods: float = 0.0) -> None:
        self.span_ns = span_s * 1e9  #: longest stamp jump counted as lost samples, ns
        self.pause_periods = pause_periods
        self.lost = 0  #: samples estimated lost so far
        self.pauses = 0  #: stamp jumps longer than span_s (pauses, not losses)
        self.paused_s = 0.0  #: their total length, s
        self.period_ns: float | None = None  #: the stream's sample period, once known
        self.gap_ns: float | None = None  #: shortest difference counted as a loss, once known
        self._last_ns: int | None = None
        self._dts: list[int] = []  # the latest stamp differences, ns
        self._behind = 0.0  # ns the stream is behind its schedule since a long step
        self._steps_left = 0  # steps until the samples of that long step are counted
        self._spread_ns = 0.0  # robust std of the steps, ns
        self._mean_ns: float | None = None  # mean of the steps that are no loss, ns
        self._mean_steps = 0  # steps in it (at most MEAN_STEPS, then an exponential mean)
        self._quiet_ns = 0.0  # smaller deviations from the period are jitter, not catching up

    @property
    def pending(self) -> int:
        """Samples the stream is behind its schedule by, not yet counted lost."""
        return max(round(self._behind / self._mean_ns), 0) if self._mean_ns else 0

    def observe(self, stamp_ns: int) -> bool:
        """Take the stamp (integer ns) of the next sample received; return whether it
        follows a pause (or a clock that went back)."""
        last = self._last_ns
        if last is None or stamp_ns > last:
            self._last_ns = stamp_ns
        if last is None or stamp_ns <= last:
            # the first, a repeated or a late one: nothing known missing
            return last is not None and stamp_ns < last - self.span_ns
        dt = stamp_ns - last
        if dt > self.span_ns and (self.period_ns is None
                                  or dt > self.pause_periods * self.period_ns):
            self.settle()
            self.pauses += 1
            self.paused_s += dt / 1e9
            return True
        dts = self._dts
        catching_up = (self._steps_left and self.period_ns is not None
                       and dt < self.period_ns - self._quiet_ns)
        if not catching_up:  # short steps after a long one would bias the period low
            dts.append(dt)
            mean = self._mean_ns
            if mean is not None and self.gap_ns is not None and dt < self.gap_ns:
                self._mean_steps = min(self._mean_steps + 1, MEAN_STEPS)
                self._mean_ns = mean + (dt - mean) / self._mean_steps
        if len(dts) == PERIOD_SAMPLES or (self.period_ns is None and len(dts) >= 3):
            period = float(statistics.median(dts))
            spread = 1.4826 * statistics.median(abs(d - period) for d in dts)  # ≈ std
            self.period_ns = period
            self.gap_ns = max(LOST_GAP * period, period + JITTER_MADS * spread)
            self._spread_ns = spread
            if self._mean_ns is None or abs(self._mean_ns - period) > 0.1 * period:
                self._mean_ns, self._mean_steps = period, 0  # the first, or the rate changed
            if len(dts) == PERIOD_SAMPLES:
                dts.clear()
        period_ns, gap_ns = self._mean_ns, self.gap_ns
        if period_ns is None or gap_ns is None:
            return False
        long_step = dt >= gap_ns
        if long_step or self._steps_left:
            excess = dt - period_ns
            if long_step and not self._steps_left:
                self._quiet_ns = max(QUIET_MADS * self._spread_ns, QUIET_PERIODS * period_ns)
            if long_step or excess < -self._quiet_ns:  # catching up, not a steady clock's jitter
                self._behind += excess
            self._steps_left = LOSS_HORIZON if long_step else self._steps_left - 1
            if self._behind < 0.5 * period_ns or not self._steps_left:
                self.settle()  # back on schedule (nothing lost), or given up waiting
        return False

    def settle(self) -> None:
        """Count what the stream is still behind its schedule by as lost (end of stream)."""
        self.lost += self.pending
        self._behind, self._steps_left = 0.0, 0


def _level(problems: list[tuple[Level, str]], summary: str) -> tuple[Level, str]:
    if not problems:
        return Level.OK, summary
    return max(level for level, _ in problems), '; '.join(text for _, text in problems)


def _number(value: float | None, digits: int = 4) -> str:
    return 'n/a' if value is None or math.isnan(value) else f'{value:.{digits}g}'


def identifier_health(*, period_s: float, since_sample_s: float | None, processed: int,
                      skipped_total: int, lost: int, learnt: int, recent_processed: int,
                      recent_skipped: int, recent_lost: int,
                      period_worst_lag_ms: float | None,
                      error_finite: bool, validation_nmse_total: float | None,
                      learning: bool, update_rate: float | None = None,
                      update_overdue_s: float | None = None,
                      contact_armed: bool | None = None,
                      contact_thresholds: Sequence[float] | None = None,
                      contact_arm_nmse: float | None = None, contact_why_not: str = '',
                      contact_false_alarms_per_hour: float | None = None,
                      contact_segments: float | None = None, contact_held: int = 0,
                      contact_delay_p50_ms: float | None = None,
                      contact_delay_p99_ms: float | None = None) -> Health:
    """The identifier's health over the last ``period_s`` seconds.

    Parameters
    ----------
    period_s : float
        Seconds since the previous report, > 0.
    since_sample_s : float or None
        Seconds since the latest sample; None if none yet.
    processed, skipped_total, lost, learnt : int
        Counters since start (``skipped_total``: all reasons together); ``recent_*``
        their growth over the period.
    period_worst_lag_ms : float or None
        Largest delay from a sample's stamp to its prediction in the period (ms).
    error_finite : bool
        Whether the windowed prediction error is finite.
    validation_nmse_total : float or None
        Held-out NMSE over all joints.
    update_rate : float or None
        Weight updates/s of a trainer beside the stream; None for one in the message path.
    update_overdue_s : float or None
        Seconds such a trainer's due update has waited (its samples came, no update
        finished: the CPU is too busy for its lower priority); None if none is due.
    contact_armed : bool or None
        Whether contact detection is armed; None: no contact detection.
    contact_thresholds : sequence of float or None
        Per-joint thresholds on |measured − predicted − its median| (N·m or N), None until
        known.
    contact_why_not : str
        Why detection is not armed ('' when armed).
    contact_false_alarms_per_hour : float or None
        The false-alarm rate the held-out residuals' tail gives at the thresholds.
    contact_segments : float or None
        Independent held-out segments the thresholds come from.
    contact_held : int
        Samples not checked (since start) because their q, q', q'' left the calibrated
        envelope.
    contact_delay_p50_ms, contact_delay_p99_ms : float or None
        The contact decision's delay from the sample's stamp over the period (ms).
    """
    rate = recent_processed / period_s
    problems: list[tuple[Level, str]] = []
    if not error_finite:
        problems.append((Level.ERROR, 'prediction error is not finite: call ~/reset'))
    if recent_lost:
        text = (f'{recent_lost} samples lost in the last {period_s:.1f} s (stamp gaps > '
                f'{LOST_GAP:g} periods): the publisher, the network or a full queue dropped '
                'them')
        problems.append((Level.ERROR, text))
    if since_sample_s is None:
        text = 'no sample received yet: is joint_states published and remapped to this node?'
        problems.append((Level.WARN, text))
    elif since_sample_s > STALE_AFTER:
        text = (f'no sample for {since_sample_s:.1f} s (> {STALE_AFTER:g} s): has the '
                'joint_states publisher stopped?')
        problems.append((Level.WARN, text))
    if recent_processed and recent_skipped / recent_processed > SKIPPED_WARN:
        text = (f'{recent_skipped / recent_processed:.0%} of the samples skipped '
                f'(> {SKIPPED_WARN:.0%}): see the log for why')
        problems.append((Level.WARN, text))
    if validation_nmse_total is not None and validation_nmse_total > NMSE_WARN:
        text = (f'validation NMSE {validation_nmse_total:.3g} > {NMSE_WARN:g}: the model '
                'predicts worse than the mean (as it does in its first seconds of learning)')
        problems.append((Level.WARN, text))
    if learning and update_overdue_s is not None and update_overdue_s > STALL_AFTER:
        text = (f'learning stalled: no update for {update_overdue_s:.0f} s while samples came '
                '(the learner process runs below the stream in CPU priority and the CPU is '
                'busy; lm_nice:=0 gives it an equal share): predictions go on with the last '
                'weights')
        problems.append((Level.WARN, text))
    updates = f' ({update_rate:.1f} updates/s)' if learning and update_rate is not None else ''
    level, message = _level(problems, f"identifying at {rate:.0f} samples/s, learning "
                                      f"{'on' if learning else 'off'}{updates}")
    return Health(level, message, {
        **({'updates/s': f'{update_rate:.2f}'} if update_rate is not None else {}),
        'samples/s': f'{rate:.1f}', 'lag [ms]': _number(period_worst_lag_ms, 3),
        'processed': str(processed), 'skipped': str(skipped_total), 'lost': str(lost),
        'learnt': str(learnt), 'learning': str(learning).lower(),
        'validation NMSE': _number(validation_nmse_total),
        **_contact_values(contact_armed, contact_thresholds, contact_arm_nmse,
                          contact_why_not, contact_false_alarms_per_hour, contact_segments,
                          contact_held, contact_delay_p50_ms, contact_delay_p99_ms)})


def _contact_values(armed: bool | None, thresholds: Sequence[float] | None,
                    arm_nmse: float | None, why_not: str = '',
                    per_hour: float | None = None, segments: float | None = None,
                    held: int = 0, delay_p50_ms: float | None = None,
                    delay_p99_ms: float | None = None) -> dict[str, str]:
    """The diagnostics values about contact detection (none without it)."""
    if armed is None:
        return {}
    below = f'validation NMSE < {arm_nmse:g}' if arm_nmse is not None else 'identified'
    state = 'armed' if armed else f"not armed ({why_not or 'until ' + below})"
    if held:
        state += (f'; {held} samples held: q, q\' or q\'\' outside the calibrated envelope, '
                  'not checked')
    return {'contact detection': state,
            'contact thresholds': ('none yet' if thresholds is None
                                   else ', '.join(_number(v) for v in thresholds)),
            'contact false alarms/h (estimated)': _number(per_hour, 3),
            'contact independent segments': _number(segments, 4),
            'contact held (outside envelope)': str(held),
            'contact delay p50 / p99 [ms]': (f'{_number(delay_p50_ms, 3)} / '
                                             f'{_number(delay_p99_ms, 3)}')}


def simulator_health(*, period_s: float, nominal_hz: float, published: int, late: int,
                     recent_published: int, recent_late: int, waiting: bool) -> Health:
    """The simulator's health over the last ``period_s`` seconds.

    Parameters
    ----------
    nominal_hz : float
        Rate it should publish at (``rate_hz`` × real-time factor); 0: no rate check.
    published, late : int
        Samples published and late by more than one period, since start; ``recent_*``
        their growth over the period.
    waiting : bool
        Still waiting for subscribers, nothing published yet on purpose.
    """
    rate = recent_published / period_s
    problems: list[tuple[Level, str]] = []
    if not waiting:
        if nominal_hz > 0 and rate < RATE_ERROR * nominal_hz:
            text = (f'publishing {rate:.0f} samples/s, less than {RATE_ERROR:.0%} of '
                    f'{nominal_hz:g} Hz')
            problems.append((Level.ERROR, text))
        if recent_published and recent_late / recent_published > LATE_WARN:
            text = (f'{recent_late} of {recent_published} samples late (> {LATE_WARN:.0%}): '
                    'the machine cannot keep real time')
            problems.append((Level.WARN, text))
    summary = ('waiting for subscribers' if waiting
               else f'publishing {rate:.0f} samples/s')
    level, message = _level(problems, summary)
    return Health(level, message, {
        'samples/s': f'{rate:.1f}', 'nominal [Hz]': f'{nominal_hz:g}',
        'published': str(published), 'late': str(late), 'late in period': str(recent_late)})


def recorder_health(*, period_s: float, written: int, received: int, paused: int,
                    recent_written: int, is_paused: bool, files: int, topics: int) -> Health:
    """The recorder's health over the last ``period_s`` seconds.

    Parameters
    ----------
    written, received, paused : int
        Messages written, received, and received while paused, since start.
    files, topics : int
        Storage files of the bag so far, topics recorded.
    """
    rate = recent_written / period_s
    problems = ([(Level.WARN, 'paused: messages are not written, call ~/resume')]
                if is_paused else [])
    level, message = _level(problems, f'writing {rate:.0f} messages/s on {topics} topic(s)')
    return Health(level, message, {
        'write rate [msg/s]': f'{rate:.1f}', 'written': str(written),
        'received': str(received), 'not written (paused)': str(paused),
        'files': str(files), 'topics': str(topics)})
