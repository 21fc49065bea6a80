"""PersonMethod.in_the_way_of, which returns at once when its person can neither keep nor start
making way, against the full pass over every other robot it shortens: the same answers and the
same remembered sets over random walks of four bodies round a corridor (a person before the
corridor, inside it, past it and arrived)."""

from __future__ import annotations

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.sim.agent import RobotView
from nodnav.sim.person import PersonMethod


def full_pass(person: PersonMethod, i: int, view: RobotView) -> list[int]:
    """The round before's in_the_way_of: every array computed, every other robot looked at."""
    s, gap_limit = person.scenario, person.params.make_way_gap
    p = view.positions
    gaps = np.linalg.norm(p - p[i], axis=1) - s.radii - s.radii[i]
    under_way = np.linalg.norm(p - s.destinations, axis=1) > s.sim.goal_tolerance
    inside = s.world.in_corridor(p)
    side = int(person.sides[i])
    before = side != 0 and i not in person.arrived and int(s.world.side_of(p[i][None])[0]) == side
    held = person.making_way.setdefault(i, set())
    for k in range(s.n_robots):
        if k == i:
            continue
        coming_out = before and bool(inside[k]) and int(person.sides[k]) == -side
        if k in held:
            keep = coming_out if k in person.coming_out.get(i, set()) else (
                bool(under_way[k]) and gaps[k] < 2.0 * gap_limit)
            if not keep:
                held.discard(k)
                person.coming_out.get(i, set()).discard(k)
        elif (gaps[k] < gap_limit or person._waiting(k, i, view, gaps[k])) and (
                (i in person.arrived and under_way[k]) or coming_out):
            held.add(k)
            if coming_out:
                person.coming_out.setdefault(i, set()).add(k)
    return sorted(held)


def test_in_the_way_of_is_the_full_pass():
    scenario = load_scenario("4r-case4")
    rngs = [np.random.default_rng(k) for k in range(scenario.n_robots)]
    fast, plain = PersonMethod(scenario, rngs), PersonMethod(scenario, rngs)
    rng = np.random.default_rng(11)
    answers = set()
    coming_out = False
    for walk in range(40):
        p = rng.uniform(-4.5, 4.5, size=(scenario.n_robots, 2))
        p[:, 1] *= 0.3
        for method in (fast, plain):
            method.arrived = {0} if walk % 3 == 0 else set()
        for step in range(30):
            p = p + rng.normal(0.0, 0.15, size=p.shape)
            v = rng.normal(0.0, 0.3, size=p.shape) * (rng.random((len(p), 1)) < 0.5)
            view = RobotView(t=0.1 * step, window_times=np.array([0.0]),
                             window_states=np.concatenate([p, v], axis=1)[:, None, :], entered=())
            for i in range(scenario.n_robots):
                got, expected = fast.in_the_way_of(i, view), full_pass(plain, i, view)
                assert got == expected
                answers.add(tuple(got))
            assert fast.making_way == plain.making_way and fast.coming_out == plain.coming_out
            coming_out = coming_out or any(fast.coming_out.values())
    assert len(answers) > 3 and coming_out  # nobody, one, several; some of them coming out of the corridor
