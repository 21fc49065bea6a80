"""The mutual braking convention: of every two robots that keep the rule, exactly one takes the weak check."""

from types import SimpleNamespace

import numpy as np
import pytest

from nodnav.api import load_scenario
from nodnav.sim.methods import make_team
from nodnav.sim.simulator import trial_generators


def _method(mode, methods=None):
    overrides = {"execution.mutual_braking": mode}
    for i, m in enumerate(methods or []):
        overrides[f"robots[{i}].method"] = m
    scenario = load_scenario("4r-case1", overrides)
    rngs, _ = trial_generators(0, scenario.n_robots)
    return scenario, make_team(scenario, "nod", rngs)


def _strong(method, scenario, view):
    n = scenario.n_robots
    out = np.zeros((n, n), dtype=bool)
    for i in range(n):
        partners = method._partners(i, view)
        others = [k for k in range(n) if k != i]
        out[i, others] = partners.strong
    return out


@pytest.mark.parametrize("mode", ["speed", "index"])
def test_exactly_one_weak_check_per_pair(mode):
    scenario, method = _method(mode)
    rng = np.random.default_rng(5)
    n = scenario.n_robots
    for _ in range(50):
        speeds = rng.choice([0.0, 0.5, 1.0], n)  # ties included
        angles = rng.uniform(0, 2 * np.pi, n)
        view = SimpleNamespace(positions=rng.uniform(-3, 3, (n, 2)), age=None,
                               velocities=speeds[:, None] * np.c_[np.cos(angles), np.sin(angles)])
        strong = _strong(method, scenario, view)
        for i in range(n):
            for j in range(i + 1, n):
                assert strong[i, j] != strong[j, i]
                if mode == "speed" and speeds[i] != speeds[j]:
                    assert not strong[i if speeds[i] > speeds[j] else j, j if speeds[i] > speeds[j] else i]


def test_strong_towards_everyone_and_towards_other_methods():
    scenario, method = _method("strong")
    n = scenario.n_robots
    view = SimpleNamespace(positions=np.arange(2 * n, dtype=float).reshape(n, 2), velocities=np.zeros((n, 2)),
                           age=None)
    strong = _strong(method, scenario, view)
    assert strong[~np.eye(n, dtype=bool)].all()
    scenario, team = _method("speed", ["nod", "nod", "person", "nod"])
    nod = team.members["nod"]
    assert nod.keeps_rule.tolist() == [True, True, False, True]
    for i in (0, 1, 3):
        assert nod._partners(i, view).strong[[k for k in range(n) if k != i].index(2)]


def test_none_and_unseen_robots():
    scenario, method = _method("none")
    view = SimpleNamespace(positions=np.zeros((4, 2)), velocities=np.zeros((4, 2)), age=None)
    assert method._partners(0, view) is None
    scenario, method = _method("speed")
    view = SimpleNamespace(positions=np.zeros((4, 2)), velocities=np.zeros((4, 2)),
                           age=np.array([0.0, 0.0, np.inf, 0.3]))
    assert len(method._partners(0, view).positions) == 1  # only robot 1 is seen now
