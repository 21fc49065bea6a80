"""A robot's opinions over the passing orders of its own game (Section III, bounded by N_i).

Eq. (5) has robot ``i`` weigh strategy ``j`` against strategy ``l`` only through
``A^{jl}_ik``, which is 1 exactly when ``j`` and ``l`` prescribe the same order for ``i`` and its
game players ``N_i``. So all that eqs. (4), (5) and (8) ever distinguish is the order a strategy
gives the robots of the *game* ``G_i = {i} u N_i``: its projection onto ``G_i``. Strategies with
the same projection receive the same social term, and, starting alike (zero initial opinions, no
bias), keep the same opinion. The robot therefore keeps one opinion per order of its game,
``(k+1)!`` of them for ``k`` players, instead of one per order of all ``N_r`` robots, and:

* eq. (5) sums over all ``N_s = N_r!`` strategies ``l``: each order of the game stands for the
  ``N_r! / (k+1)!`` strategies that project onto it (:func:`class_size`), so its social term is
  that many times the estimate for one of them, exactly as the sum over ``l`` counts them;
* eq. (3) over all strategies gives each order of the game the summed probability of the
  strategies that project onto it: the softmax over the game's orders of their common opinion;
* a bias ``b_ij`` given per strategy becomes, per order of the game, the log-mean-exp of the
  biases of the strategies that project onto it (:func:`game_bias`): the opinion whose softmax
  weight is theirs together, exact at the steady state of eq. (8).

When ``N_i(t)`` changes, the robot's opinions are carried to the new game by what they say about
the robots the two games share (:func:`carry_opinions`): each order of the new game gets the
log-mean-exp of the opinions of the old orders that agree with it on the shared robots, so the
probability the robot gave to every order of the shared robots is kept, and robots new to the
game start with no preference about where they go. A representation over all ``N_r!`` orders
would instead remember what the robot had learnt about robots that left its game; with a game
that does not change the two are the same (``tests/decision/test_games.py``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from nodnav.decision.strategies import passing_orders


def game_orders(game: tuple[int, ...]) -> np.ndarray:
    """Every passing order of the robots ``game`` (scenario indices), ``((k+1)!, k+1)``, in the
    lexicographic order of their places in ``game``: row ``m`` is ``game[passing_orders(k+1)[m]]``."""
    return np.asarray(game, dtype=int)[passing_orders(len(game))]


def class_size(n_robots: int, game_size: int) -> float:
    """How many of the ``N_r!`` strategies project onto each order of a game of ``game_size``
    robots: ``N_r! / (k+1)!``."""
    return float(math.prod(range(game_size + 1, n_robots + 1)))


def projection_keys(orders: np.ndarray, robots) -> list[tuple[int, ...]]:
    """Each order of ``orders`` ``(M, g)`` restricted to ``robots``, as a tuple (a class key)."""
    members = {int(k) for k in robots}
    return [tuple(int(k) for k in row if int(k) in members) for row in np.asarray(orders)]


def log_mean_exp(values: np.ndarray, eta: float) -> float:
    """``eta log mean exp(values / eta)``: the value whose softmax weight is the mean of theirs."""
    v = np.asarray(values, dtype=float) / eta
    if v.ndim == 1 and len(v):  # max and mean as their reductions without the wrappers (mean: sum / count)
        top = np.maximum.reduce(v)
        return float(eta * (top + np.log(np.add.reduce(np.exp(v - top)) / len(v))))
    top = v.max()
    return float(eta * (top + np.log(np.mean(np.exp(v - top)))))


@functools.lru_cache(maxsize=4096)
def carry_groups(old_game: tuple[int, ...], new_game: tuple[int, ...]) -> tuple[list[np.ndarray], list[int]]:
    """How :func:`carry_opinions` groups the orders of ``old_game``: the indices of the old orders
    that put the robots of both games in the same order, one array per group (in the order the
    groups first appear), and the group of each order of ``new_game``. A function of the games
    alone, kept for the games asked again (read-only)."""
    shared = [k for k in new_game if k in old_game]
    groups: dict[tuple[int, ...], list[int]] = {}
    for j, key in enumerate(projection_keys(game_orders(old_game), shared)):
        groups.setdefault(key, []).append(j)
    place = {key: g for g, key in enumerate(groups)}
    members = [np.array(rows, dtype=int) for rows in groups.values()]
    for rows in members:
        rows.flags.writeable = False
    return members, [place[key] for key in projection_keys(game_orders(new_game), shared)]


def carry_opinions(z: np.ndarray, old_game: tuple[int, ...], new_game: tuple[int, ...], eta: float,
                   groups: tuple[list[np.ndarray], list[int]] | None = None) -> np.ndarray:
    """Opinions over the orders of ``new_game`` from ``z`` over those of ``old_game``
    (:func:`game_orders`): each new order gets the log-mean-exp of the old orders that put the
    robots of both games in the same order; ``z`` itself when the game is the same. ``groups``:
    :func:`carry_groups` of the two games, if the caller holds it."""
    if tuple(old_game) == tuple(new_game):
        return np.asarray(z, dtype=float)
    members, group_of = carry_groups(tuple(old_game), tuple(new_game)) if groups is None else groups
    z = np.asarray(z, dtype=float)
    carried = [log_mean_exp(z[rows], eta) for rows in members]
    return np.array([carried[g] for g in group_of])


def game_bias(bias: dict[int, float], game: tuple[int, ...], n_robots: int, eta: float) -> np.ndarray:
    """The bias of eq. (5) over the orders of ``game``, from ``bias`` given per strategy index
    (0-based, among :func:`~nodnav.decision.strategies.passing_orders` of ``n_robots``; strategies
    not named have no bias): the log-mean-exp over the strategies that project onto each order.
    With every robot in the game, the strategies' own biases."""
    orders = game_orders(game)
    size = class_size(n_robots, len(game))
    out = np.zeros(len(orders))
    if not bias:
        return out
    named: dict[tuple[int, ...], list[float]] = {}
    for j, value in bias.items():
        key = tuple(k for k in strategy_order(j, n_robots) if k in set(game))
        named.setdefault(key, []).append(float(value))
    for m, key in enumerate(projection_keys(orders, game)):
        values = np.array(named.get(key, [])) / eta
        # The strategies not named have bias 0; log-mean-exp over all `size` of them, stably.
        terms = np.concatenate([values, [math.log(size - len(values))] if size > len(values) else []])
        top = terms.max()
        out[m] = eta * (top + math.log(np.exp(terms - top).sum()) - math.log(size))
    return out


def strategy_order(j: int, n_robots: int) -> tuple[int, ...]:
    """The passing order of strategy index ``j`` (0-based, lexicographic) of ``n_robots`` robots,
    without listing the others (the inverse of :func:`~nodnav.decision.strategies.strategy_index`)."""
    remaining = list(range(n_robots))
    order = []
    for pos in range(n_robots, 0, -1):
        block = math.factorial(pos - 1)
        order.append(remaining.pop(j // block))
        j %= block
    return tuple(order)


def selections_agree(ranks: np.ndarray, robots) -> bool:
    """Whether the robots' selected orders agree on the order of ``robots``.

    ``ranks`` ``(N_r, N_r)``: ``ranks[i, k]`` is the place of robot ``k`` in robot ``i``'s selected
    order of its game (-1 when ``k`` is not in it; a row of -1 is a robot that selected none,
    never agreeing). They agree when no two selections put two of ``robots`` in opposite orders;
    with every robot in every game this is the same order for ``robots`` in every selection. With
    fewer than two of ``robots`` nothing is left to agree on.
    """
    ranks = np.asarray(ranks)
    if (ranks.max(axis=1) < 0).any():
        return False
    robots = list(robots)
    if len(robots) < 2:
        return True
    r = ranks[:, robots]  # (N_r, R)
    for a in range(len(robots)):
        for b in range(a + 1, len(robots)):
            both = (r[:, a] >= 0) & (r[:, b] >= 0)
            first = r[both, a] < r[both, b]
            if first.any() and not first.all():
                return False
    return True
