"""Game-player selection by conflict likelihood, eqs. (6)-(7) (Section III-A)."""

from __future__ import annotations

import numpy as np


def conflict_likelihood(positions: np.ndarray, corridor_distances: np.ndarray, delta: float = 1.0) -> np.ndarray:
    """Conflict likelihoods ``L_ij = 1/(d_ij + delta) + 1/(d_i,corr + d_j,corr + delta)``, eq. (6).

    Parameters
    ----------
    positions : ``(N, 2)`` robot positions (m); ``d_ij`` is their Euclidean distance.
    corridor_distances : ``(N,)`` distances ``d_i,corridor`` to the entrance each robot
        approaches (m), zero inside the corridor (:meth:`nodnav.scenario.world.World.corridor_distance`).
    delta : positive offset (m) keeping ``L`` finite and bounded by ``2 / delta``; paper: 1.

    Returns
    -------
    ``(N, N)`` symmetric matrix with a zero diagonal (a robot is never its own game player).
    """
    if delta <= 0:
        raise ValueError(f"delta must be positive, got {delta}")
    p = np.asarray(positions, dtype=float)
    c = np.asarray(corridor_distances, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or c.shape != (p.shape[0],):
        raise ValueError(f"positions must be (N, 2) and corridor_distances (N,), got {p.shape} and {c.shape}")
    d = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
    L = 1.0 / (d + delta) + 1.0 / (c[:, None] + c[None, :] + delta)
    np.fill_diagonal(L, 0.0)
    return L


def select_game_players(L: np.ndarray, i: int, k: int) -> tuple[int, ...]:
    """The ``k`` game players ``N_i`` maximising ``sum_{j in N_i} L_ij``, eq. (7), in increasing order.

    The maximising subset is the ``k`` largest ``L_ij`` with ``j != i``; equal likelihoods are
    broken in favour of the lower index, so every robot evaluating ``L`` gets the same answer.
    ``k = 0`` gives ``()``.
    """
    L = np.asarray(L, dtype=float)
    n = L.shape[0]
    if L.shape != (n, n):
        raise ValueError(f"L must be square, got shape {L.shape}")
    if not 0 <= i < n:
        raise ValueError(f"robot {i} is not among the {n} robots")
    if not 0 <= k <= n - 1:
        raise ValueError(f"k must be between 0 and {n - 1}, got {k}")
    row = L[i].tolist()
    if any(v != v for v in row):  # NaN: numpy's ordering (last), which Python's sort does not keep
        others = np.delete(np.arange(n), i)
        ranked = others[np.argsort(-L[i, others], kind="stable")]
        return tuple(sorted(int(j) for j in ranked[:k]))
    # The stable sort by -L_ij, as argsort(kind="stable") of the negated row: ties keep the lower index.
    ranked_list = sorted((j for j in range(n) if j != i), key=lambda j: -row[j])
    return tuple(sorted(ranked_list[:k]))


def game_player_mask(L: np.ndarray, k: int) -> np.ndarray:
    """Every robot's game players at once: ``(N, N)`` boolean, ``mask[i, j]`` true when ``j`` is in
    ``N_i`` as chosen by :func:`select_game_players`. Not symmetric in general."""
    n = np.asarray(L).shape[0]
    mask = np.zeros((n, n), dtype=bool)
    for i in range(n):
        mask[i, list(select_game_players(L, i, k))] = True
    return mask


def undecided_first(L: np.ndarray, entered) -> np.ndarray:
    """Conflict likelihoods with the robots that have ``entered`` the corridor ranked after every
    other (not in the paper): their place in the order is decided, so eq. (7) picks them only when
    fewer than ``k`` robots are still to decide. The order among each group is eq. (6)'s."""
    L = np.array(L, dtype=float)
    done = np.zeros(L.shape[0], dtype=bool)
    done[list(entered)] = True
    lowest = L.min() - 1.0
    L[:, done] = lowest - (L.max() - L[:, done])  # below every undecided robot, in the same order
    np.fill_diagonal(L, 0.0)
    return L
