"""Draws in which robots meet inside the passage, and passages with a bay (issue 19, item 6).

Families place robots inside the corridor in one of three ways (``inside.order``, weights):

* ``apart`` (the default, as before issue 19): those heading left left of those heading right,
  so that nobody must pass anybody;
* ``any``: in any order, so robots inside may face each other;
* ``facing``: two teams facing each other, 1-3 robots a side (2 to ``inside.max`` in all, all of
  the scenario's robots if it has no more): those heading right on the left. One side must back
  out, or duck into a bay, before the other can pass; the witness of solvability knows it
  (:mod:`nodnav.scenario.backing_out`).

``inside.bays`` is the probability that one wall of the corridor has a bay: a niche
``2 r_max + 0.2`` to ``2 r_max + 0.5`` m long and ``2 r_max + 0.2`` m deep, somewhere between
the mouths, that one robot fits into beside the line (the planner finds it from the walls,
:mod:`nodnav.planning.waiting_spots`). Families that keep the defaults draw exactly what they drew before.
"""

from __future__ import annotations

from nodnav.scenario.bay_walls import with_bay
from nodnav.scenario.families import Family
from nodnav.scenario.layout import MIN_WALL, _Attempt, _mm, _Robot
from nodnav.scenario.validity import CLEARANCE
from nodnav.scenario.world import INSIDE, LEFT, RIGHT

#: Most robots of a team inside the corridor (``facing``).
TEAM_MAX = 3


class MeetingAttempt(_Attempt):
    """One draw of a family whose robots inside may meet (:data:`Family.inside_order` other than
    ``apart`` alone) or whose corridor may have a bay."""

    def __init__(self, f: Family, d):
        super().__init__(f, d)
        self.order = d.choice(f.inside_order) if len(f.inside_order) > 1 else f.inside_order[0][0]

    def robots(self) -> list[_Robot]:
        robots = super().robots()
        if self.order != "facing":
            return robots
        d, f, n = self.d, self.f, len(robots)
        top = min(f.inside_max, n)
        if top < 2:
            return robots  # no room for a team a side: as drawn
        right = d.integer(1, min(TEAM_MAX, top - 1))
        left = d.integer(1, min(TEAM_MAX, top - right))
        m = n - right - left
        out_left = d.integer(0, m)
        roles = ([(LEFT, RIGHT)] * out_left + [(RIGHT, LEFT)] * (m - out_left)
                 + [(INSIDE, RIGHT)] * right + [(INSIDE, LEFT)] * left)
        return [_Robot(r.radius, r.speed, s, g, r.accel) for r, (s, g) in zip(robots, roles)]

    def inside(self, group: list[_Robot]) -> None:
        if self.order == "apart" or not group:
            super().inside(group)
            return
        placed = sorted(group, key=lambda r: -r.goal) if self.order == "facing" else self.d.shuffled(group)
        group[:] = placed
        self._place(group)

    def mapping(self, seed: int, robots: list[_Robot]) -> dict:
        out = super().mapping(seed, robots)
        if self.f.bays <= 0.0 or not self.d.chance(self.f.bays):
            return out
        d, h, half = self.d, self.h, self.half
        r_max = max(r.radius for r in robots)
        length = _mm(2 * r_max + 2 * CLEARANCE + 0.1 + d.uniform(0.0, 0.3))
        depth = _mm(2 * r_max + 2 * CLEARANCE + 0.1)
        upper = d.chance(0.5)
        x0_, y0, x1_, y1 = out["world"]["bounds"]
        room = (y1 - half) if upper else (-half - y0)  # wall beside the corridor on that side
        if 2 * h < length + 0.2 or room < depth + MIN_WALL:
            return out  # no room for a bay: as drawn
        centre = d.uniform(-h + length / 2 + 0.1, h - length / 2 - 0.1)
        x0, x1 = _mm(centre - length / 2), _mm(centre + length / 2)
        world = dict(out["world"])
        world["obstacles"] = with_bay(world["obstacles"], h, half, x0, x1, depth, upper)
        out["world"] = world
        out["description"] += f", a bay {x1 - x0:.2f} x {depth:.2f} m at x = {centre:.2f}"
        return out


def attempt_for(family: Family, d) -> _Attempt:
    """The attempt class a family's draws need: :class:`MeetingAttempt` for a family with robots
    inside that may meet or with bays, else the plain one (whose draws are as before issue 19)."""
    if family.inside_order == (("apart", 1.0),) and family.bays <= 0.0:
        return _Attempt(family, d)
    return MeetingAttempt(family, d)
