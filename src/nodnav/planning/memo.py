"""Bounded memos: the planners remember recent answers, forgetting the oldest first."""

from __future__ import annotations

from typing import Any

#: How many entries a memo keeps (a four-robot state needs about a hundred).
MEMO_SIZE = 1024


def remember(memo: dict, key: Any, value: Any) -> None:
    """Store ``value`` under ``key`` in ``memo``, forgetting the oldest entry when it holds :data:`MEMO_SIZE`."""
    if len(memo) >= MEMO_SIZE:
        del memo[next(iter(memo))]
    memo[key] = value


def remember_within(memo: dict, key: Any, value: Any, size: int) -> None:
    """:func:`remember` with room for ``size`` entries."""
    if len(memo) >= size:
        del memo[next(iter(memo))]
    memo[key] = value


#: How many entries the memos that only serve the requests of one state keep (the closed loop
#: asks every order of a round from one state, and a few states interleave when robots plan
#: different groups): small, so that they hold few objects for the garbage collector to scan.
ROUND_MEMO_SIZE = 128


def remember_briefly(memo: dict, key: Any, value: Any) -> None:
    """:func:`remember` with room for :data:`ROUND_MEMO_SIZE` entries."""
    if len(memo) >= ROUND_MEMO_SIZE:
        del memo[next(iter(memo))]
    memo[key] = value


class remembered_property:  # noqa: N801 (named like the property it stands for)
    """``functools.cached_property`` without its lock: computed on first read and kept in the
    instance's ``__dict__`` (later reads find it there without calling this descriptor). On
    Python 3.11 the lock costs about a microsecond per first read, and the planner makes
    thousands of motions and plans per round; the planners are not shared between threads."""

    def __init__(self, func):
        self.func = func
        self.name = func.__name__
        self.__doc__ = func.__doc__

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, instance, owner=None):
        if instance is None:
            return self
        value = instance.__dict__[self.name] = self.func(instance)
        return value
