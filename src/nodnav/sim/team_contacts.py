"""Contacts with people, who caused them, and the figures of a mixed team per robot and per method.

A contact between two robots, or between a robot and a wall, ends a trial as it always has. A
contact involving a person (:mod:`nodnav.sim.person`) does not by itself: people bump into
each other and into robots and walk on. Each such contact is recorded once, when it begins, with
who caused it, and a trial ends in a collision (kind ``robot-person``) only when a *robot* moved
into a person.

Attribution ("who moved into whom"): at the sub-step where two bodies first touch, with ``n`` the
unit vector from ``a`` to ``b`` and ``v_a``, ``v_b`` their velocities over the step, each one's
*approach speed* is its velocity along the line of centres towards the other, ``u_a = v_a . n``
and ``u_b = -v_b . n``. The one with the larger approach speed moved into the other and caused
the contact; equal approach speeds (within 1e-9 m/s) make both causes. A robot standing still
that a person walks into did not cause the contact; a robot driving into a person standing still
did.
"""

from __future__ import annotations

import math

import numpy as np

from nodnav.planning.visibility import VisibilityGraph
from nodnav.scenario.schema import Scenario

#: Approach speeds closer than this (m/s) make both bodies causes of their contact.
TIE = 1e-9


def approach_speeds(p_a: np.ndarray, p_b: np.ndarray, v_a: np.ndarray, v_b: np.ndarray) -> tuple[float, float]:
    """How fast ``a`` moves towards ``b`` and ``b`` towards ``a`` along their line of centres (m/s)."""
    d = np.asarray(p_b, dtype=float) - np.asarray(p_a, dtype=float)
    norm = float(np.hypot(*d))
    if norm == 0.0:
        return 0.0, 0.0
    n = d / norm
    return float(np.dot(v_a, n)), float(-np.dot(v_b, n))


def contact_causes(approach_a: float, approach_b: float) -> tuple[bool, bool]:
    """Whether ``a`` and whether ``b`` caused their contact: the larger approach speed; both when equal."""
    if abs(approach_a - approach_b) <= TIE:
        return True, True
    return approach_a > approach_b, approach_b > approach_a


class PeopleContacts:
    """The contacts involving people in one trial, found step by step and recorded as events.

    Each event is ``{"t", "kind": "contact", "robots": [a, b], "people": [..], "approach": [u_a,
    u_b], "caused_by": [...]}`` (robots numbered from 0, as in every event); a person touching a
    wall (which clipped motion should prevent) is ``"robots": [a], "wall": true``.
    """

    def __init__(self, scenario: Scenario, pedestrians: np.ndarray):
        self.scenario = scenario
        self.pedestrians = np.asarray(pedestrians, dtype=bool)
        n = scenario.n_robots
        a, b = np.triu_indices(n, k=1)
        keep = self.pedestrians[a] | self.pedestrians[b]
        self.pairs = np.stack([a[keep], b[keep]], axis=1)
        """Pairs of robots (``a < b``) of which at least one is a person."""
        radii = scenario.radii
        self._pair_columns = (self.pairs[:, 0], self.pairs[:, 1])
        self._pair_list = [tuple(pair) for pair in self.pairs.tolist()]
        self._pair_reach = radii[self.pairs[:, 0]] + radii[self.pairs[:, 1]]  # each pair's sum of radii
        self._people = np.flatnonzero(self.pedestrians)
        self._people_reach = radii[self._people] - scenario.sim.collision_tolerance
        self.touching: set[tuple[int, ...]] = set()
        """Pairs (and single people at a wall) in contact at the last step."""

    def judge(self, start: np.ndarray, path: np.ndarray, t: float, dt: float, events: list[dict]) -> int:
        """Record the contacts with people that begin over a step from ``start`` ``(N, 2)``
        through ``path`` ``(S, N, 2)`` (its sub-steps, ending where the robots are at ``t + dt``);
        return how many of them a robot (not a person) caused."""
        s = self.scenario
        tol = s.sim.collision_tolerance
        a_of, b_of = self._pair_columns
        # Every pair's gaps at every sub-step at once: the same products, sums and roots as pair by pair.
        hits = np.linalg.norm(path[:, a_of] - path[:, b_of], axis=2) - self._pair_reach < -tol
        now: set[tuple[int, ...]] = set()
        robot_caused = 0
        velocities = None
        for column in np.flatnonzero(hits.any(axis=0)).tolist():
            a, b = self._pair_list[column]
            now.add((a, b))
            if (a, b) in self.touching:
                continue
            if velocities is None:
                velocities = (path[-1] - start) / dt
            first = int(np.argmax(hits[:, column]))
            u_a, u_b = approach_speeds(path[first, a], path[first, b], velocities[a], velocities[b])
            cause_a, cause_b = contact_causes(u_a, u_b)
            caused_by = [k for k, c in ((a, cause_a), (b, cause_b)) if c]
            events.append({"t": round(t + dt * (first + 1) / len(path), 6), "kind": "contact", "robots": [a, b],
                           "people": [bool(self.pedestrians[a]), bool(self.pedestrians[b])],
                           "approach": [round(u_a, 6), round(u_b, 6)], "caused_by": caused_by})
            robot_caused += any(not self.pedestrians[k] for k in caused_by)
        if len(self._people):  # every person's clearance at every sub-step in one call
            at_wall = (s.world.clearance(path[:, self._people]) < self._people_reach).any(axis=0)
            for a in self._people[at_wall].tolist():
                now.add((a,))
                if (a,) not in self.touching:
                    events.append({"t": round(t + dt, 6), "kind": "contact", "robots": [a], "wall": True,
                                   "people": [True], "caused_by": [a]})
        self.touching = now
        return robot_caused


def free_times(scenario: Scenario) -> np.ndarray:
    """Each robot's time alone (s): its shortest route among the walls at its top speed."""
    out = np.full(scenario.n_robots, np.nan)
    graphs: dict[float, VisibilityGraph] = {}
    for i, r in enumerate(scenario.robots):
        graph = graphs.setdefault(r.radius, VisibilityGraph(scenario.world, r.radius))
        path = graph.shortest_path(np.asarray(r.origin, dtype=float), np.asarray(r.destination, dtype=float))
        if path.success:
            out[i] = path.length / r.max_speed
    return out


def team_metrics(scenario: Scenario, methods: tuple[str, ...], pedestrians: np.ndarray, arrival: np.ndarray,
                 events: list[dict], outcome: str) -> dict:
    """The figures of a mixed team: who runs what, contacts by cause, arrival and delay per method.

    ``delay_s`` of a robot is its arrival time minus :func:`free_times` (NaN if it did not
    arrive). ``success_contact_free`` is the strict reading of success: every robot and person
    arrived and no robot touched anyone, whoever caused it.
    """
    ped = np.asarray(pedestrians, dtype=bool)
    contacts = [e for e in events if e.get("kind") == "contact"]
    by_robot = sum(any(not ped[k] for k in e["caused_by"]) for e in contacts)
    by_people = sum(all(ped[k] for k in e["caused_by"]) for e in contacts)
    touched_robot = any(any(not ped[k] for k in e["robots"]) for e in contacts)
    delay = np.asarray(arrival, dtype=float) - free_times(scenario)
    per_method: dict[str, dict] = {}
    for name in dict.fromkeys(methods):
        members = [i for i, m in enumerate(methods) if m == name]
        times = np.asarray(arrival, dtype=float)[members]
        arrived = np.isfinite(times)
        per_method[name] = {
            "robots": [i + 1 for i in members],
            "arrived": int(arrived.sum()),
            "last_arrival_s": float(times.max()) if arrived.all() else math.nan,
            "mean_delay_s": float(np.nanmean(delay[members])) if arrived.any() else math.nan,
        }
    robots = ~ped
    robots_arrived = bool(np.isfinite(np.asarray(arrival, dtype=float)[robots]).all())
    return {
        "robot_methods": list(methods),
        "people": [i + 1 for i in np.flatnonzero(ped).tolist()],
        "contacts": len(contacts),
        "contacts_caused_by_robots": int(by_robot),
        "contacts_caused_by_people": int(by_people),
        "robots_arrived": robots_arrived,
        "people_arrived": bool(np.isfinite(np.asarray(arrival, dtype=float)[ped]).all()),
        "robots_makespan_s": float(np.max(np.asarray(arrival)[robots])) if robots_arrived and robots.any()
        else math.nan,
        "delay_s": [float(d) for d in delay],
        "success_contact_free": bool(outcome == "success" and not touched_robot),
        "per_method": per_method,
    }
