"""The Nonlinear Opinion Dynamics (NOD) model: eqs. (1)-(3), (5), (8) and (9) of the paper.

Shapes: opinions are ``(N_r, N_s)`` arrays, row ``i`` robot ``i``'s opinion state ``z_i``, column
``j`` strategy ``S_{j+1}`` (0-based, see :mod:`nodnav.decision.strategies`). Per-robot parameters
(``u_i``, ``d_i``) are scalars or ``(N_r,)`` arrays; the bias ``b_ij`` is anything that broadcasts
to the opinions.

Weights inside or outside the saturation
----------------------------------------
The paper writes the social term as ``R(A zbar)``: eq. (1) ``R(A^j_ik zbar_kj)`` and eq. (5)
``R(A^{jl}_ik zbar_kl)``. Read literally, a zero weight contributes ``R(0) = 1/2``, so in eq. (5)
every pair of strategies ``(j, l)`` with different projected orders adds a constant ``1/2``. We
implement the weight outside the saturation, ``A R(zbar)``, in both equations, because:

* the two readings agree wherever the weight is 1, which is every use in the paper's
  experiments of eq. (1) (all ``A^j_ik = 1``);
* in eq. (5) with the consistency weights of Section III-B, each strategy ``j`` has the same
  number of strategies ``l`` with its projected order (all classes of a projection have size
  ``N_s / (|N_i| + 1)!``), so the literal reading adds the same constant
  ``|N_i| (N_s - N_s / (|N_i| + 1)!) / 2`` to the social sum of every ``z_ij``, and
  ``d_i u_i`` times it to every rate of robot ``i``. A per-robot constant changes
  neither the relative opinions (2), nor the probabilities (3), nor (through (2)) any other
  robot's rate: the two readings give identical strategy selections at all times;
* with the weight outside, eq. (5) reduces *exactly* to eq. (1) when ``N_i`` holds every other
  robot and ``A^{jl}_ik = A^j_ik delta_jl`` (the paper's claim below eq. (5)); with the literal
  reading it reduces only up to that constant.

The one case where the readings differ in substance is a per-strategy mask in eq. (1)
(``A^j_ik = 0`` for some ``j`` only): here an unobserved pair scores 0 rather than ``1/2``.
"""

from __future__ import annotations

import numpy as np


def relative_opinions(z: np.ndarray) -> np.ndarray:
    """Relative opinions ``zbar_kj = z_kj - N_s^{-1} sum_l z_kl`` over the last axis, eq. (2)."""
    z = np.asarray(z, dtype=float)
    if not z.shape or not z.shape[-1]:  # mean's own warnings and errors
        return z - z.mean(axis=-1, keepdims=True)
    # mean's own operations (its sum over the axis, then the division by the count) without its wrapper
    return z - np.add.reduce(z, axis=-1, keepdims=True) / z.shape[-1]


def saturation(x: np.ndarray) -> np.ndarray:
    """The saturation ``R(x) = (tanh(x) + 1) / 2``, increasing from 0 to 1, eq. (9)."""
    return 0.5 * (np.tanh(np.asarray(x, dtype=float)) + 1.0)


def strategy_probabilities(z: np.ndarray, eta: float = 1.0) -> np.ndarray:
    """Strategy-selection probabilities ``x_ij = softmax(z_i / eta)_j`` over the last axis, eq. (3).

    Shifted by the row maximum before exponentiating, so opinions in the thousands neither
    overflow nor underflow to ``0/0``.
    """
    if eta <= 0:
        raise ValueError(f"eta must be positive, got {eta}")
    s = np.asarray(z, dtype=float) / eta
    # max and sum over the last axis are these reductions, without their wrappers
    e = np.exp(s - np.maximum.reduce(s, axis=-1, keepdims=True))
    return e / np.add.reduce(e, axis=-1, keepdims=True)


def selection_probabilities(x: np.ndarray, available: np.ndarray) -> np.ndarray:
    """The probabilities of eq. (3) restricted to the ``available`` strategies ``(N_s,)`` and
    renormalised: a robot cannot select a strategy it has no joint path for. ``x`` itself when
    every strategy is available; proportional to ``available`` when ``x`` puts no mass on it;
    ``x`` when none is.
    """
    x = np.asarray(x, dtype=float)
    available = np.asarray(available, dtype=bool)
    if available.all() or not available.any():
        return x
    kept = np.where(available, x, 0.0)
    total = kept.sum()
    if total <= 0.0:
        return available / available.sum()
    return kept / total


def _per_robot(p) -> np.ndarray:
    """A per-robot parameter (scalar or ``(..., N_r)``) shaped to broadcast against opinions."""
    return np.asarray(p, dtype=float)[..., None]


def opinion_rate(z: np.ndarray, u, d, b, A: np.ndarray | None = None) -> np.ndarray:
    """Opinion rates ``dz_ij/dt`` of every robot, eq. (1):

    ``dz_ij/dt = -d_i (z_ij - u_i sum_{k != i} A^j_ik R(zbar_kj) - b_ij)``

    with ``zbar`` from eq. (2) and ``R`` from eq. (9). The weight multiplies the saturated score
    (see the module docstring); the term ``k = i`` is always excluded.

    Parameters
    ----------
    z : ``(..., N_r, N_s)`` opinions; leading axes are independent systems (e.g. a grid of
        initial conditions) sharing the parameters.
    u, d : attention and resistance, scalars or ``(..., N_r)``.
    b : bias, broadcastable to ``z``.
    A : ``(N_r, N_r, N_s)`` weights ``A[i, k, j] = A^j_ik`` in {0, 1}; default all ones.
    """
    z = np.asarray(z, dtype=float)
    n_r, n_s = z.shape[-2:]
    w = np.ones((n_r, n_r, n_s)) if A is None else np.asarray(A, dtype=float)
    if w.shape != (n_r, n_r, n_s):
        raise ValueError(f"A must have shape {(n_r, n_r, n_s)}, got {w.shape}")
    w = w * (1.0 - np.eye(n_r))[:, :, None]
    social = np.einsum("ikj,...kj->...ij", w, saturation(relative_opinions(z)))
    return -_per_robot(d) * (z - _per_robot(u) * social - np.asarray(b, dtype=float))


def social_sum(r: np.ndarray, players: np.ndarray, A: np.ndarray) -> np.ndarray:
    """The social sum ``sum_{k in N_i} sum_l A^{jl}_i r_ikl`` of eqs. (5) and (8), shape ``(N_r, N_s)``.

    Parameters
    ----------
    r : saturated scores of the candidate players: ``(N_k, N_s)`` when every robot sees the same
        scores ``R(zbar_kl)`` (eq. (5)), or ``(N_r, N_k, N_s)`` when robot ``i`` has its own
        estimates ``r^l_ik = R(zbar'_kl)`` (eqs. (4) and (8)).
    players : ``(N_r, N_k)`` boolean mask, true when candidate ``k`` is in ``N_i``.
    A : consistency weights ``A[i, j, l] = A^{jl}_i`` in {0, 1}, ``(N_r, N_s, N_s)``, or one
        ``(N_s, N_s)`` matrix shared by every robot (see
        :func:`nodnav.decision.strategies.consistency_weights`).
    """
    mask = np.asarray(players, dtype=float)
    if mask.ndim != 2:
        raise ValueError(f"players must be a 2-D mask (N_r, N_k), got shape {mask.shape}")
    n_r, n_k = mask.shape
    r = np.asarray(r, dtype=float)
    n_s = r.shape[-1]
    scores = np.broadcast_to(r, (n_r, n_k, n_s))
    weights = np.broadcast_to(np.asarray(A, dtype=float), (n_r, n_s, n_s))
    return np.einsum("ik,ijl,ikl->ij", mask, weights, scores)


def generalized_opinion_rate(z: np.ndarray, u, d, b, players: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Opinion rates with game players, eq. (5):

    ``dz_ij/dt = -d_i (z_ij - u_i sum_{k in N_i} sum_l A^{jl}_i R(zbar_kl) - b_ij)``.

    The weight multiplies the saturated score instead of sitting inside ``R`` as the paper
    writes it; this shifts every rate of robot ``i`` by the same constant and so changes no
    relative opinion and no strategy probability, and makes eq. (5) reduce exactly to eq. (1) (module docstring).

    Parameters
    ----------
    z : ``(N_r, N_s)`` opinions.
    u, d : scalars or ``(N_r,)``.
    b : bias, broadcastable to ``z``.
    players : ``(N_r, N_r)`` boolean mask, ``players[i, k]`` true when ``k`` is in ``N_i``; the
        diagonal is ignored (a robot is never its own player).
    A : ``(N_r, N_s, N_s)`` consistency weights ``A[i, j, l] = A^{jl}_i``, or one ``(N_s, N_s)``.
    """
    z = np.asarray(z, dtype=float)
    mask = np.asarray(players, dtype=bool) & ~np.eye(z.shape[0], dtype=bool)
    social = social_sum(saturation(relative_opinions(z)), mask, A)
    return -_per_robot(d) * (z - _per_robot(u) * social - np.asarray(b, dtype=float))


def step_size(t, alpha_min: float = 0.05):
    """Step size ``alpha(t) = max(1 / (t + 1), h)`` of eq. (8) with ``h = alpha_min`` (footnote).

    ``t`` is the update time ``0, T, 2T, ...`` as in the paper (the update count when ``T = 1``).
    ``1 / (t + 1)`` alone satisfies ``sum alpha = inf`` and ``sum alpha^2 < inf``; the floor keeps
    opinions responsive over a finite run.
    """
    if isinstance(t, float) and isinstance(alpha_min, float) and alpha_min == alpha_min:
        # One time, as Algorithm 1 asks it: np.maximum of two doubles without the array calls
        # (NaN in t propagates as np.maximum's does).
        a = 1.0 / (t + 1.0)
        return np.float64(a if not a < alpha_min else alpha_min)
    return np.maximum(1.0 / (np.asarray(t, dtype=float) + 1.0), alpha_min)


def opinion_update(z: np.ndarray, social: np.ndarray, u, d, b, alpha) -> np.ndarray:
    """One discrete opinion update ``z - alpha d (z - u social - b)``, eq. (8).

    ``social`` is the social sum ``sum_{k in N_i} sum_l r^{jl}_ik`` (:func:`social_sum`), with the
    shape of ``z`` (``(N_r, N_s)`` or one robot's ``(N_s,)``); ``u`` and ``d`` are scalars or one
    value per row of ``z``.
    """
    z = np.asarray(z, dtype=float)
    if isinstance(u, float) and isinstance(d, float):  # one robot's scalars: the same products, unreshaped
        rate = d * (z - u * np.asarray(social, dtype=float) - np.asarray(b, dtype=float))
    else:
        rate = _per_robot(d) * (z - _per_robot(u) * np.asarray(social, dtype=float) - np.asarray(b, dtype=float))
    return z - alpha * rate
