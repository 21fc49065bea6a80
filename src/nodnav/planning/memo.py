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
