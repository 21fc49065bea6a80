"""A scenario turned and moved as a whole: the rotation test of issue 20 and a way to write a
scenario at any angle from one along x.

Turning by ``angle`` about the origin and then moving by ``shift`` maps every point ``p`` to
``R p + shift``. The world's boundary box becomes the box around the turned boundary; the parts
of that box outside the turned boundary become wall triangles (none for quarter turns). Box
walls become polygons (turned rectangles), the passage is given by its turned mouths, robots'
origins and destinations are turned. Everything else (robots' sizes and limits, opinions,
planner, controller) is unchanged.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from nodnav.scenario.polygons import box_polygon
from nodnav.scenario.schema import Scenario, scenario_from_dict, scenario_to_dict


def rotation(angle_deg: float) -> np.ndarray:
    """The rotation matrix of ``angle_deg`` degrees, exact for multiples of 90 degrees."""
    quarter = angle_deg / 90.0
    if quarter == round(quarter):
        c, s = ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(round(quarter)) % 4]
    else:
        a = math.radians(angle_deg)
        c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def transform_points(points: np.ndarray, angle_deg: float, shift=(0.0, 0.0)) -> np.ndarray:
    """``R p + shift`` for each point ``(..., 2)``."""
    p = np.asarray(points, dtype=float)
    return p @ rotation(angle_deg).T + np.asarray(shift, dtype=float)


def untransform_points(points: np.ndarray, angle_deg: float, shift=(0.0, 0.0)) -> np.ndarray:
    """The inverse of :func:`transform_points`: ``R^T (p - shift)``."""
    p = np.asarray(points, dtype=float) - np.asarray(shift, dtype=float)
    return p @ rotation(angle_deg)


def _pt(p: np.ndarray) -> list[float]:
    return [float(p[0]), float(p[1])]


def transformed_world_raw(world_raw: dict, passage: tuple, angle_deg: float, shift=(0.0, 0.0)) -> dict:
    """The ``world`` section of the turned and moved scenario (``passage``: start, end, width)."""
    def tf(p):
        return transform_points(np.asarray(p, dtype=float), angle_deg, shift)

    x0, y0, x1, y1 = world_raw["bounds"]
    corners = tf(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))  # counter-clockwise
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    walls: list[Any] = []
    for o in world_raw["obstacles"]:
        poly = box_polygon(o) if len(o) == 4 and not isinstance(o[0], (list, tuple)) else o
        walls.append([_pt(q) for q in tf(np.asarray(poly, dtype=float))])
    # The box around the turned boundary minus the turned boundary: a triangle at each corner of
    # the box, between the two boundary corners that touch the box's sides there.
    box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    scale = max(float(np.ptp(corners)), 1.0)
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        # the box corner on the outer side of the boundary edge a -> b (to its right)
        edge = b - a
        outside = [c for c in box if edge[0] * (c[1] - a[1]) - edge[1] * (c[0] - a[0]) < -1e-12 * scale * scale]
        for c in outside:
            tri = np.array([a, c, b])
            area = 0.5 * abs((c[0] - a[0]) * (b[1] - a[1]) - (c[1] - a[1]) * (b[0] - a[0]))
            if area > 1e-9 * scale * scale:
                walls.append([_pt(q) for q in tri])
    start, end, width = passage
    return {"bounds": [float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])], "obstacles": walls,
            "passages": [{"from": _pt(tf(start)), "to": _pt(tf(end)), "width": float(width)}]}


def transform_scenario(scenario: Scenario, angle_deg: float, shift=(0.0, 0.0)) -> Scenario:
    """``scenario`` turned by ``angle_deg`` degrees about the origin, then moved by ``shift`` (m)."""
    raw = scenario_to_dict(scenario)
    g = scenario.world.passage
    raw["world"] = transformed_world_raw(raw["world"], (g.start, g.end, g.width), angle_deg, shift)
    for robot in raw["robots"]:
        for key in ("origin", "destination"):
            robot[key] = _pt(transform_points(np.asarray(robot[key], dtype=float), angle_deg, shift))
    return scenario_from_dict(raw, f"{scenario.name} turned {angle_deg:g} degrees")
