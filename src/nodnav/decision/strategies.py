"""Navigation strategies: passing orders through the corridor (Sections II-B-1 and III-B).

Robots are indexed from 0 in arrays; the paper numbers robots and strategies from 1, so
strategy index ``j`` here is the paper's ``S_{j+1}``.
"""

from __future__ import annotations

from itertools import permutations

import numpy as np


def passing_orders(n_robots: int) -> np.ndarray:
    """All ``N_s = N_r!`` passing orders in lexicographic order, shape ``(N_s, N_r)``.

    Row ``j`` is strategy ``S_{j+1}``; for three robots row 2 is ``(1, 0, 2)``, the paper's
    S3 = (2, 1, 3).
    """
    if n_robots < 1:
        raise ValueError(f"n_robots must be at least 1, got {n_robots}")
    return np.array(list(permutations(range(n_robots))), dtype=int).reshape(-1, n_robots)


def strategy_label(j: int) -> str:
    """The paper's name of strategy index ``j`` (0-based): ``S1``, ``S2``, ..."""
    return f"S{j + 1}"


def order_label(order: tuple[int, ...] | np.ndarray) -> str:
    """A passing order in the paper's notation with robots numbered from 1, e.g. ``(2,1,3)``."""
    return "(" + ",".join(str(int(k) + 1) for k in order) + ")"


def strategy_index(order: tuple[int, ...] | np.ndarray) -> int:
    """Index (0-based) of a full passing order among :func:`passing_orders`."""
    order = tuple(int(k) for k in order)
    n = len(order)
    if sorted(order) != list(range(n)):
        raise ValueError(f"{order} is not a permutation of 0..{n - 1}")
    # Lehmer code: rank of the permutation in lexicographic order.
    rank, remaining = 0, list(range(n))
    fact = [1] * (n + 1)
    for m in range(1, n + 1):
        fact[m] = fact[m - 1] * m
    for pos, k in enumerate(order):
        idx = remaining.index(k)
        rank += idx * fact[n - 1 - pos]
        remaining.pop(idx)
    return rank


def project_order(order: tuple[int, ...] | np.ndarray, subset) -> tuple[int, ...]:
    """The passing order restricted to ``subset``: the robots of ``subset`` in the order they pass."""
    members = {int(k) for k in subset}
    return tuple(int(k) for k in order if int(k) in members)


def projected_order_ids(orders: np.ndarray, subset) -> np.ndarray:
    """For each strategy, an integer that is equal for two strategies exactly when their
    projections onto ``subset`` are equal, shape ``(N_s,)``."""
    members = np.zeros(orders.shape[1], dtype=bool)
    members[list(subset)] = True
    keys: dict[tuple[int, ...], int] = {}
    ids = np.empty(len(orders), dtype=int)
    for j, order in enumerate(orders):
        key = tuple(int(k) for k in order if members[k])
        ids[j] = keys.setdefault(key, len(keys))
    return ids


def consistency_weights(orders: np.ndarray, robot: int, players) -> np.ndarray:
    """A^{jl}_{ik} of Section III-B for ``k`` in the game players, shape ``(N_s, N_s)``.

    ``A^{jl} = 1`` when strategies ``j`` and ``l`` prescribe the same passing order for robot
    ``i`` and its game players ``N_i``, else 0. For ``k`` outside ``N_i`` the weight is 0; apply
    that with the player mask. With all robots as players this is the identity, and eq. (5)
    reduces to eq. (1).
    """
    ids = projected_order_ids(orders, [robot, *players])
    return (ids[:, None] == ids[None, :]).astype(float)


def precedence_mask(orders: np.ndarray, first: int, second: int) -> np.ndarray:
    """Which of ``orders`` ``(N_s, N_r)`` let robot ``first`` pass before robot ``second``, ``(N_s,)``."""
    orders = np.asarray(orders)
    return np.argmax(orders == first, axis=1) < np.argmax(orders == second, axis=1)
