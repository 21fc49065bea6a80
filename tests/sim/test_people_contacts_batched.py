"""PeopleContacts.judge (every pair and person at once) against the pair-by-pair reference it
replaced: the same events, in the same order, bit for bit, over random steps with contacts."""

from __future__ import annotations

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.sim.team_contacts import PeopleContacts, approach_speeds, contact_causes


def judge_pair_by_pair(people: PeopleContacts, touching: set, start, path, t, dt, events) -> tuple[int, set]:
    """The loop over pairs and people of the round before: one norm per pair, one clearance per person."""
    s = people.scenario
    tol, radii = s.sim.collision_tolerance, s.radii
    velocities = (path[-1] - start) / dt
    now: set = set()
    robot_caused = 0
    for a, b in people.pairs.tolist():
        gaps = np.linalg.norm(path[:, a] - path[:, b], axis=1) - (radii[a] + radii[b])
        hit = np.flatnonzero(gaps < -tol)
        if not len(hit):
            continue
        now.add((a, b))
        if (a, b) in touching:
            continue
        first = int(hit[0])
        u_a, u_b = approach_speeds(path[first, a], path[first, b], velocities[a], velocities[b])
        cause_a, cause_b = contact_causes(u_a, u_b)
        caused_by = [k for k, c in ((a, cause_a), (b, cause_b)) if c]
        events.append({"t": round(t + dt * (first + 1) / len(path), 6), "kind": "contact", "robots": [a, b],
                       "people": [bool(people.pedestrians[a]), bool(people.pedestrians[b])],
                       "approach": [round(u_a, 6), round(u_b, 6)], "caused_by": caused_by})
        robot_caused += any(not people.pedestrians[k] for k in caused_by)
    for a in np.flatnonzero(people.pedestrians).tolist():
        clear = s.world.clearance(path[:, a])
        if (clear < radii[a] - tol).any():
            now.add((a,))
            if (a,) not in touching:
                events.append({"t": round(t + dt, 6), "kind": "contact", "robots": [a], "wall": True,
                               "people": [True], "caused_by": [a]})
    return robot_caused, now


def test_batched_judge_is_the_pair_by_pair_one():
    scenario = load_scenario("4r-case4")
    rng = np.random.default_rng(3)
    for pedestrians in ([True, False, False, False], [True, True, False, False], [False, True, False, True]):
        people = PeopleContacts(scenario, np.array(pedestrians))
        touching: set = set()
        found = 0
        for step in range(300):
            # Four bodies crowded round a point near a corridor mouth, some overlapping, some in a wall.
            start = rng.normal([-1.2, 0.0], 0.35, size=(4, 2))
            path = start + np.cumsum(rng.normal(0.0, 0.03, size=(4, 4, 2)), axis=0)
            mine: list[dict] = []
            reference: list[dict] = []
            expected, now = judge_pair_by_pair(people, set(touching), start, path, 0.1 * step, 0.1, reference)
            assert people.judge(start, path, 0.1 * step, 0.1, mine) == expected
            assert mine == reference and people.touching == now
            touching = now
            found += len(reference)
        assert found > 20  # contacts of every kind were met
