"""When to publish each message of a bag: the player's timing, without ROS.

A bag's messages carry their log (reception) times. Played at ``rate`` r, a message
logged ``dt`` after the first one is due ``dt / r`` after playback started; rate 0
(``'max'``) publishes as fast as possible. With ``loop`` the bag starts over after its
last message, each pass shifted by the duration of the ones before (plus one mean
message period, so the first message of a pass does not share the instant of the last
one of the previous pass). Topic selection uses :class:`TopicFilter`; remapping
``old:=new`` renames topics on the way out::

    remap = parse_remaps(['/joint_states:=/replayed/joint_states'])
    for item in schedule(lambda: bag.messages(topics), timeline=Timeline(2.0), loop=True):
        sleep_until(start + item.due_ns)
        publish(remap.get(item.message.topic, item.message.topic), item.message.data)

Everything here is pure and deterministic: times are integer nanoseconds, relative to
the start of playback (``due_ns``) or as recorded (``log_time_ns``).
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

from scara_ident_ros.bag.errors import BagError
from scara_ident_ros.bag.reader import BagMessage

__all__ = ['PlaybackError', 'SINGLE_MESSAGE_PERIOD_NS', 'Scheduled', 'Timeline', 'parse_rate',
           'parse_remaps', 'schedule']

SINGLE_MESSAGE_PERIOD_NS = 1_000_000_000  # ns between passes over a one-message bag


class PlaybackError(BagError, ValueError):
    """A bad playback rate or remapping (one line); a ValueError, as any bad value."""


def parse_rate(value: str | float) -> float:
    """Parse a playback rate: a number > 0, or ``0``/``'max'`` for as fast as possible.

    Raises
    ------
    PlaybackError
        If it is negative, not finite or not a number.
    """
    if isinstance(value, str) and value.strip().lower() in ('max', 'inf'):
        return 0.0
    try:
        rate = float(value)
    except ValueError:
        raise PlaybackError(f"rate must be a number > 0, or 0 or 'max', got {value!r}") from None
    if rate < 0 or not math.isfinite(rate):
        raise PlaybackError(f"rate must be a number > 0, or 0 or 'max', got {value!r}")
    return rate


_TOPIC_NAME = re.compile(r'(/[A-Za-z_][A-Za-z0-9_]*)+')  # absolute, no '//', no trailing '/'


def parse_remaps(items: Iterable[str]) -> dict[str, str]:
    """Parse ``old:=new`` topic remappings into ``{'/old': '/new'}``.

    Raises
    ------
    PlaybackError
        If an item has no ``:=``, an empty side, a side that is not a valid ROS topic name
        (tokens of letters, digits and ``_``, not starting with a digit, joined by ``/``), or
        a topic is remapped twice.
    """
    remaps: dict[str, str] = {}
    for item in items:
        old, sep, new = item.partition(':=')
        old, new = old.strip(), new.strip()
        if not sep or not old or not new:
            raise PlaybackError(f"remap must look like 'old:=new', got {item!r}")
        old = old if old.startswith('/') else '/' + old
        new = new if new.startswith('/') else '/' + new
        for name in (old, new):
            if not _TOPIC_NAME.fullmatch(name):
                raise PlaybackError(f'{name!r} in remap {item!r} is not a valid ROS topic name')
        if old in remaps:
            raise PlaybackError(f'topic {old} is remapped twice')
        remaps[old] = new
    return remaps


@dataclass(frozen=True)
class Timeline:
    """Maps recorded time to playback time at ``rate`` (0 = as fast as possible).

    Attributes
    ----------
    rate : float
        Playback speed: 1.0 real time, 2.0 twice as fast, 0.0 no waiting.
    """

    rate: float = 1.0

    def __post_init__(self) -> None:
        parse_rate(self.rate)

    @property
    def as_fast_as_possible(self) -> bool:
        """True for rate 0."""
        return self.rate == 0

    def due_ns(self, recorded_ns: int) -> int:
        """Playback time (ns since start) of something ``recorded_ns`` after the first message."""
        if self.as_fast_as_possible:
            return 0
        return round(recorded_ns / self.rate)

    def recorded_ns(self, due_ns: int) -> int:
        """Inverse of :meth:`due_ns`: recorded time elapsed at playback time ``due_ns``."""
        if self.as_fast_as_possible:
            return 0
        return round(due_ns * self.rate)


@dataclass(frozen=True)
class Scheduled:
    """A message and when to publish it.

    Attributes
    ----------
    message : BagMessage
        As recorded (topic not remapped).
    due_ns : int
        When to publish it, ns after the start of playback (0 at rate 0).
    clock_ns : int
        The recorded time to publish on ``/clock`` with it: its log time, shifted by the
        duration of the previous passes when looping, so the clock never goes back.
    loop_pass : int
        0 for the first pass through the bag, 1 for the second, ...
    """

    message: BagMessage
    due_ns: int
    clock_ns: int
    loop_pass: int


def schedule(open_messages: Callable[[], Iterable[BagMessage]], *, timeline: Timeline,
             loop: bool = False, max_passes: int | None = None) -> Iterator[Scheduled]:
    """Yield every message with its due time, pass after pass when looping.

    ``open_messages()`` returns a fresh iterable of the messages in log-time order (once
    per pass); ``max_passes`` (None: forever) bounds the passes when looping.
    """
    offset = 0  # recorded ns taken by the previous passes
    start_log = 0  # log time of the very first message
    loop_pass = 0
    while True:
        pass_first: int | None = None
        last_log = 0
        count = 0
        for message in open_messages():
            if pass_first is None:
                pass_first = message.log_time_ns
                if loop_pass == 0:
                    start_log = pass_first
            elapsed = offset + message.log_time_ns - pass_first
            yield Scheduled(message, timeline.due_ns(elapsed), start_log + elapsed, loop_pass)
            last_log = message.log_time_ns
            count += 1
        loop_pass += 1
        if not loop or pass_first is None or (max_passes is not None
                                              and loop_pass >= max_passes):
            return
        span = last_log - pass_first
        period = span // (count - 1) if count > 1 else SINGLE_MESSAGE_PERIOD_NS
        offset += span + max(period, 1)
