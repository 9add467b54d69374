"""The player's timing: due times scale with the rate, loops continue the clock."""
from __future__ import annotations

import pytest

from scara_ident_ros.bag import BagMessage, Timeline, parse_rate, parse_remaps, schedule

MESSAGES = [BagMessage('/a', 'x/msg/T', t, bytes([i])) for i, t in
            enumerate([1_000_000_000, 1_010_000_000, 1_030_000_000])]


def test_rate_scales_the_due_times() -> None:
    for rate, expected in [(1.0, [0, 10_000_000, 30_000_000]),
                           (2.0, [0, 5_000_000, 15_000_000]),
                           (0.5, [0, 20_000_000, 60_000_000]),
                           (0.0, [0, 0, 0])]:
        items = list(schedule(lambda: MESSAGES, timeline=Timeline(rate)))
        assert [i.due_ns for i in items] == expected
        assert [i.message for i in items] == MESSAGES
        assert [i.clock_ns for i in items] == [m.log_time_ns for m in MESSAGES]


def test_loop_shifts_each_pass_by_the_bag_duration_and_a_period() -> None:
    items = list(schedule(lambda: iter(MESSAGES), timeline=Timeline(1.0), loop=True,
                          max_passes=3))
    assert [i.loop_pass for i in items] == [0, 0, 0, 1, 1, 1, 2, 2, 2]
    # span 30 ms, mean period 15 ms: each pass starts 45 ms after the previous one
    assert [i.due_ns // 1_000_000 for i in items] == [0, 10, 30, 45, 55, 75, 90, 100, 120]
    clocks = [i.clock_ns for i in items]
    assert clocks == sorted(clocks) and clocks[3] == 1_045_000_000


def test_loop_over_an_empty_bag_ends() -> None:
    assert list(schedule(lambda: [], timeline=Timeline(1.0), loop=True)) == []


def test_single_message_loops_once_a_second() -> None:
    items = list(schedule(lambda: MESSAGES[:1], timeline=Timeline(1.0), loop=True,
                          max_passes=3))
    assert [i.due_ns for i in items] == [0, 1_000_000_000, 2_000_000_000]


@pytest.mark.parametrize('text, rate', [('1', 1.0), ('2.5', 2.5), ('max', 0.0), ('0', 0.0),
                                        (3, 3.0)])
def test_parse_rate(text: str, rate: float) -> None:
    assert parse_rate(text) == rate


@pytest.mark.parametrize('text', ['-1', 'fast', 'nan', 'inf '])
def test_bad_rates(text: str) -> None:
    if text.strip() == 'inf':
        assert parse_rate(text) == 0.0
        return
    with pytest.raises(ValueError, match='rate must be'):
        parse_rate(text)


def test_parse_remaps() -> None:
    assert parse_remaps(['joint_states:=/replay/joint_states', '/a:=b']) == {
        '/joint_states': '/replay/joint_states', '/a': '/b'}
    for bad in (['a'], ['a:='], [':=b'], ['a:=b', '/a:=c'], ['/joint_states:=bad name!'],
                ['a:=/x//y'], ['a:=/x/'], ['a:=/1x'], ['a b:=c']):
        with pytest.raises(ValueError):
            parse_remaps(bad)
