"""The MPC's data for one step: the request's values and the requirements derived from the current state."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class StepData:
    """The request's data for one step, with the requirements derived from the current state.

    Walls and other robots are handled alike, as ``G`` groups (walls first): each keeps a
    clearance from a point ``x`` at every interval end (a wall's point is the nearest point of its
    rectangle, which depends on the linearisation; another robot's is its prediction).
    """

    p0: np.ndarray
    v0: np.ndarray
    ref_local: np.ndarray
    """Reference relative to ``p0`` ``(K, 2)`` (m)."""
    pred_check: np.ndarray
    """Predicted positions of the others at the check times ``(m, C, 2)`` (m)."""
    x_now: np.ndarray
    """Each group's point at every interval end for a half-plane through the current position:
    the wall's nearest point to ``p0``, or the prediction ``(G, N, 2)`` (m)."""
    away: np.ndarray
    """Unit vector from each group's point at ``tau = 0`` to ``p0`` ``(G, 2)``."""
    dist_now: np.ndarray
    """Current distance to each group's point ``(G,)`` (m)."""
    contact: np.ndarray
    """Distance to a group's point below which a linearisation point gives no direction ``(G,)`` (m)."""
    full: np.ndarray
    """Clearance wanted from each group: r_i from a wall, r_i + r_j + margin from a robot ``(G,)`` (m)."""
    need: np.ndarray
    """Clearance to keep: ``full``, or less where the current state is already closer ``(G,)`` (m)."""
    delta_sq: np.ndarray
    """A quarter of the squared largest relative displacement over the intervals meeting at each
    end ``(G, N)`` (m^2)."""
    velocities: np.ndarray
    """Each other robot's predicted velocity at the end of the horizon ``(m, 2)`` (m/s)."""
    far: np.ndarray
    """Groups out of reach within the horizon ``(G,)``: a wall's rows then constrain nothing."""
    gap_box: np.ndarray
    """Current distance to the bounds x_min, y_min, x_max, y_max ``(4,)`` (m)."""
    need_box: np.ndarray
    """Clearance to keep from the bounds ``(4,)`` (m)."""
    static_lower: np.ndarray
    """Lower bounds of the static rows in the QP's coordinates (:meth:`MPCProblem.static_lower`)."""
    n_walls: int
    tail_weight: float = 0.0
    """``V / (2 a_tail)`` (s): the braking tail's segment runs to ``p(T) + tail_weight v(T)``; 0: no tail rows."""
    tail_reach: float = 0.0
    """Walls farther than this from ``p0`` cannot meet the tail's segment (m)."""
    box_low: np.ndarray | None = None
    """Lowest allowed position ``(2,)``: the bounds' corner plus the clearance kept from them (m)."""
    box_high: np.ndarray | None = None
    """Highest allowed position ``(2,)`` (m)."""
    need_clear: float = 0.0
    """The smallest clearance the plan has to keep from any wall or bound (m)."""
    clearance_now: float = np.inf
    """The present clearance from the walls and bounds (m)."""
    overlap: bool = False
    """Whether another robot is closer than contact (less ``settings.contact_tolerance``)."""

