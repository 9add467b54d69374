"""Which topics to record or play: names and glob patterns, or all.

Patterns are absolute topic names in which ``*`` matches any characters except ``/``
(one name component or part of one), ``**`` matches anything including ``/`` and ``?``
one character other than ``/``. So ``/*/identified_torque`` matches
``/ffmw/identified_torque`` but not ``/a/b/identified_torque``. A name without a
leading ``/`` is made absolute. With ``all_topics`` every topic matches except hidden
ones (a name component starting with ``_``), as ``ros2 bag record --all`` does.
"""
from __future__ import annotations

import re
from collections.abc import Iterable, Sequence

__all__ = ['TopicFilter']


def _compile(pattern: str) -> re.Pattern[str]:
    parts = re.split(r'(\*\*|\*|\?)', pattern)
    regex = ''.join({'**': '.*', '*': '[^/]*', '?': '[^/]'}.get(p, re.escape(p)) for p in parts)
    return re.compile(regex + r'\Z')


class TopicFilter:
    """Match topic names against names/patterns (see the module docstring).

    Parameters
    ----------
    patterns : sequence of str
        Topic names or glob patterns.
    all_topics : bool
        Match every non-hidden topic (the patterns are then ignored).

    Raises
    ------
    ValueError
        If a pattern is empty.
    """

    def __init__(self, patterns: Sequence[str] = (), *, all_topics: bool = False) -> None:
        cleaned = []
        for pattern in patterns:
            pattern = pattern.strip()
            if not pattern:
                raise ValueError('empty topic name or pattern')
            cleaned.append(pattern if pattern.startswith('/') else '/' + pattern)
        self.patterns = tuple(cleaned)
        self.all_topics = all_topics
        self._exact = {p for p in cleaned if not re.search(r'[*?]', p)}
        self._globs = [_compile(p) for p in cleaned if p not in self._exact]

    def matches(self, topic: str) -> bool:
        """Whether ``topic`` is selected."""
        if self.all_topics:
            return not any(part.startswith('_') for part in topic.split('/'))
        return topic in self._exact or any(g.match(topic) for g in self._globs)

    def select(self, topics: Iterable[str]) -> list[str]:
        """The selected topics of ``topics``, in their order."""
        return [topic for topic in topics if self.matches(topic)]

    def __repr__(self) -> str:
        return 'TopicFilter(all)' if self.all_topics else f'TopicFilter({list(self.patterns)})'
