"""The shortest duration that works: the search the approach and the stop both make.

Durations are tried from the shortest up, each ``growth`` times the one before, until one
passes its check (keeps to the limits) or the longest is passed:
:meth:`~scara_ident_ros.excitation.plan.ExcitationPlan` (the approach) and
:func:`~scara_ident_ros.excitation.stopping.plan_stop` (the stop).
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

__all__ = ['shortest_duration']

_T = TypeVar('_T')


def shortest_duration(attempt: Callable[[float], _T | None], *, shortest: float,
                      longest: float, growth: float) -> _T | None:
    """The first result of ``attempt`` that is not None, over durations growing from
    ``shortest``.

    Parameters
    ----------
    attempt : callable
        Given a duration (s), what it gives (e.g. the motion of that duration), or None if
        that duration does not do.
    shortest, longest : float
        The first duration tried and the longest one tried (s), > 0.
    growth : float
        Ratio of two durations tried, > 1.

    Returns
    -------
    The first result, or None if no duration up to ``longest`` does.
    """
    duration = shortest
    while duration <= longest:
        result = attempt(duration)
        if result is not None:
            return result
        duration *= growth
    return None
