"""Contacts between two control steps: robots that overlap each other or enter a wall at any of
the step's sub-steps, checked exactly at those positions (the simulator's judge,
:mod:`nodnav.sim.simulator`)."""

from __future__ import annotations

import math

import numpy as np

from nodnav.compiled import compiled
from nodnav.geometry import piece_clearance
from nodnav.scenario.world import clearance_of


def straight_substeps(previous: np.ndarray, current: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Positions ``(S, N, 2)`` at the fractions ``weights`` ``(S,)`` of a step from ``previous``
    to ``current`` ``(N, 2)`` along straight lines (motion at constant velocity)."""
    w = np.asarray(weights, dtype=float)[:, None, None]
    return (1.0 - w) * previous[None] + w * current[None]


@compiled
def contact_counts(path: np.ndarray, radii: np.ndarray, tol: float, bounds: np.ndarray,
                   obstacles: np.ndarray, pieces: np.ndarray) -> tuple[int, int]:
    """Pairs of robots that overlap, and robots that enter a wall, at some sub-step of a control
    step: ``path`` ``(S, N, 2)`` holds where the robots are at the step's sub-steps; contact is a
    distance ``tol`` (m) under the radii's sum, or a clearance
    (:func:`~nodnav.scenario.world.clearance_of`, and :func:`~nodnav.geometry.piece_clearance`
    for the convex pieces of polygon walls) ``tol`` under the radius."""
    n_sub, n = path.shape[0], path.shape[1]
    flat = np.ascontiguousarray(path.reshape(n_sub * n, 2))
    clear = clearance_of(flat, bounds, obstacles)
    if pieces.shape[0]:
        clear = np.minimum(clear, piece_clearance(flat, pieces))
    return contact_tally(path, radii, tol, clear)


@compiled
def contact_tally(path: np.ndarray, radii: np.ndarray, tol: float, clear: np.ndarray) -> tuple[int, int]:
    """:func:`contact_counts` given the clearance ``clear`` ``(S N,)`` of every robot at every
    sub-step (a map's world gives it through its wall index, the same values)."""
    n_sub, n = path.shape[0], path.shape[1]
    pairs, walls = 0, 0
    for i in range(n):
        hit_wall = False
        for k in range(i + 1, n):
            hit = False
            for s in range(n_sub):
                dx = path[s, i, 0] - path[s, k, 0]
                dy = path[s, i, 1] - path[s, k, 1]
                hit = hit or math.sqrt(dx * dx + dy * dy) < (radii[i] + radii[k]) - tol
            pairs += hit
        for s in range(n_sub):
            hit_wall = hit_wall or clear[s * n + i] < radii[i] - tol
        walls += hit_wall
    return pairs, walls
