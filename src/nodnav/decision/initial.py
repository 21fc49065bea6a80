"""Distance-based initial opinions, eqs. (10)-(11) (Section IV-B-1).

Robots closer to the corridor entrance are made more likely to pass first: each strategy's
initial opinion is a scaled product of the probabilities that each robot in its order is chosen
next among those still waiting, with the choice a softmax of minus the entrance distances.
"""

from __future__ import annotations

import numpy as np


def order_likelihoods(distances: np.ndarray, orders: np.ndarray) -> np.ndarray:
    """``L(i_l | i_1..i_{l-1}) = exp(-d_{i_l}) / sum_{m >= l} exp(-d_{i_m})`` for every order, eq. (10).

    Parameters
    ----------
    distances : ``(N_r,)`` initial distances ``d_i,corridor`` of the robots to their entrance (m).
    orders : ``(N_s, N_r)`` passing orders, row ``j`` the robots ``(i_1, ..., i_{N_r})`` of
        strategy ``j`` (:func:`nodnav.decision.strategies.passing_orders`).

    Returns
    -------
    ``(N_s, N_r)`` array, entry ``[j, l]`` the likelihood of the ``l``-th robot of order ``j``
    going next; the last column is 1.
    """
    d = np.asarray(distances, dtype=float)
    orders = np.asarray(orders, dtype=int)
    if orders.ndim != 2 or orders.shape[1] != d.shape[0]:
        raise ValueError(f"orders must be (N_s, {d.shape[0]}), got {orders.shape}")
    # Shifting every distance by the same amount leaves the ratios unchanged and avoids underflow.
    w = np.exp(-(d - d.min()))[orders]
    remaining = np.cumsum(w[:, ::-1], axis=1)[:, ::-1]
    return w / remaining


def distance_initial_opinions(distances: np.ndarray, orders: np.ndarray, K2: float = 10.0) -> np.ndarray:
    """Initial opinions ``z_ij(0) = prod_{l=1}^{N_r-1} K2 L(i_l | i_1..i_{l-1})``, eq. (11).

    Returns ``(N_s,)``, the same for every robot ``i``; the last factor (always 1) is left out of
    the product as in the paper.
    """
    L = order_likelihoods(distances, orders)
    return np.prod(K2 * L[:, :-1], axis=1)
