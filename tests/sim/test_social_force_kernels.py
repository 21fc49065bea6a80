"""The compiled social force kernels (nodnav.sim.social_force) against the plain NumPy functions
they replace: the same floating-point operations in the same order, so bitwise the same results."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from nodnav.control.base import STEP_FRACTIONS
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.world import Passage, World
from nodnav.sim.person import PersonMethod
from nodnav.sim.simulator import run_trial
from nodnav.sim.social_force import SocialForceParams, clip_against_walls, clipped_step, point_clearance

MARKS = np.round(STEP_FRACTIONS * SocialForceParams().substeps).astype(int)


def person_method(name: str = "4r-case4", params: SocialForceParams | None = None) -> PersonMethod:
    s = load_scenario(name)
    return PersonMethod(s, [np.random.default_rng(k) for k in range(s.n_robots)], params=params)


def random_state(rng: np.random.Generator, world: World, m: int):
    """A person somewhere free near or in the corridor (some already squeezed against a wall),
    moving, heading somewhere (or nowhere), and ``m`` others around it (some in contact)."""
    while True:
        p0 = rng.uniform([-4.0, -1.5], [4.0, 1.5])
        if float(world.clearance(p0[None])[0]) > 0.05:
            break
    v0 = rng.normal(size=2) * rng.uniform(0.0, 0.7)
    heading = rng.normal(size=2)
    e = np.zeros(2) if rng.random() < 0.15 else heading / np.hypot(*heading)
    pj = p0 + rng.normal(size=(m, 2)) * rng.uniform(0.2, 0.8)
    vj = rng.normal(size=(m, 2)) * 0.5
    rj = rng.uniform(0.15, 0.3, size=m)
    return p0, v0, e, float(rng.uniform(0.0, 1.3)), pj, vj, rj


@pytest.mark.parametrize("params", [SocialForceParams(), SocialForceParams(wall_lateral=False, behind=1.0)],
                         ids=["default", "literal-walls-isotropic"])
def test_walk_is_bitwise_the_plain_walk(params):
    person = person_method(params=params)
    world = person.scenario.world
    rng = np.random.default_rng(7)
    for case in range(240):
        state = random_state(rng, world, m=case % 4)
        p, v, passed = person.walk(0, *state, MARKS)
        p_ref, v_ref, passed_ref = person.walk_plain(0, *state, MARKS)
        assert p.tobytes() == p_ref.tobytes() and v.tobytes() == v_ref.tobytes(), case
        assert np.array(passed).tobytes() == np.array(passed_ref).tobytes(), case


def test_clipped_step_is_bitwise_clip_against_walls_among_boxes_and_polygons():
    notch = ((0.0, 0.0), (0.0, 3.0), (1.0, 3.0), (1.0, 1.0), (2.0, 1.5), (3.0, 1.0), (3.0, 0.0))
    worlds = [load_scenario("3r-case2").world,
              World(bounds=(-5.0, -5.0, 5.0, 5.0), obstacles=((-3.0, -1.0, -2.0, 2.0),),
                    passages=(Passage((-4.0, 4.0), (4.0, 4.0), 0.7),), polygons=(notch,))]
    rng = np.random.default_rng(3)
    for world in worlds:
        hits = 0
        for _ in range(3000):
            p = rng.uniform(np.array(world.bounds[:2]) + 0.05, np.array(world.bounds[2:]) - 0.05)
            if float(world.clearance(p[None])[0]) <= 0.0:
                continue
            s = rng.normal(size=2) * rng.choice([0.01, 0.1, 0.5])
            if rng.random() < 0.1:
                s[rng.integers(2)] = 0.0
            r = float(rng.uniform(0.1, 0.4))
            ref = clip_against_walls(world, p, s, r)
            got = clipped_step(p[0], p[1], s[0], s[1], r, world.obstacle_array, world.bounds_array, world.piece_array)
            assert np.array(got).tobytes() == ref.tobytes()
            assert point_clearance(p[0], p[1], world.obstacle_array, world.bounds_array,
                                   world.piece_array) == float(world.clearance(p[None])[0])
            hits += not np.array_equal(ref, s)
        assert hits > 100  # many steps were clipped


def test_a_person_trial_is_bitwise_the_plain_one(monkeypatch):
    scenario = load_scenario("2r-case1", overrides={"robots[0].method": "person"})
    compiled = run_trial(scenario, seed=2).history.arrays()
    monkeypatch.setattr(PersonMethod, "walk", PersonMethod.walk_plain)
    plain = run_trial(scenario, seed=2).history.arrays()
    for key in ("positions", "velocities"):
        assert compiled[key].tobytes() == plain[key].tobytes()


def test_walk_in_a_world_with_a_wall_index_is_bitwise_the_plain_walk():
    # A map's world clips its steps through the wall index (the plain clip_against_walls).
    s = load_scenario("4r-case4")
    s = dataclasses.replace(s, world=dataclasses.replace(s.world, map_walls=len(s.world.obstacles)))
    assert s.world.wall_grid is not None
    person = PersonMethod(s, [np.random.default_rng(k) for k in range(s.n_robots)])
    rng = np.random.default_rng(11)
    for case in range(120):
        state = random_state(rng, s.world, m=case % 3)
        p, v, passed = person.walk(0, *state, MARKS)
        p_ref, v_ref, passed_ref = person.walk_plain(0, *state, MARKS)
        assert p.tobytes() == p_ref.tobytes() and v.tobytes() == v_ref.tobytes(), case
        assert np.array(passed).tobytes() == np.array(passed_ref).tobytes(), case
