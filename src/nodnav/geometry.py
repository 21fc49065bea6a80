"""Pairwise distances between robots, shared by planners, the simulator and the metrics."""

from __future__ import annotations

import numpy as np


def pairwise_distances(positions: np.ndarray) -> np.ndarray:
    """Centre-to-centre distances, shape ``(..., n, n)`` for positions ``(..., n, 2)``."""
    p = np.asarray(positions, dtype=float)
    return np.linalg.norm(p[..., :, None, :] - p[..., None, :, :], axis=-1)


def min_pair_distance(positions: np.ndarray) -> float:
    """Smallest centre-to-centre distance over all pairs and all leading indices (m); inf for one robot."""
    p = np.asarray(positions, dtype=float)
    n = p.shape[-2]
    if n < 2:
        return float("inf")
    a, b = np.triu_indices(n, k=1)
    return float(np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1).min())


def min_gap(positions: np.ndarray, radii: np.ndarray) -> float:
    """Smallest surface-to-surface gap ``|p_a - p_b| - r_a - r_b`` over pairs and leading indices (m)."""
    p = np.asarray(positions, dtype=float)
    r = np.asarray(radii, dtype=float)
    n = p.shape[-2]
    if n < 2:
        return float("inf")
    a, b = np.triu_indices(n, k=1)
    return float((np.linalg.norm(p[..., a, :] - p[..., b, :], axis=-1) - (r[a] + r[b])).min())
