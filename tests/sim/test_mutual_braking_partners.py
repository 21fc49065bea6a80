"""What a planned method gives its controllers for the mutual braking check."""

from types import SimpleNamespace

import numpy as np

from nodnav.api import load_scenario
from nodnav.control.mutual_braking import CONVENTIONS, RESTART_HEADROOM
from nodnav.sim.methods import make_team
from nodnav.sim.simulator import trial_generators


def _method(mode, methods=None):
    overrides = {"execution.mutual_braking": mode}
    for i, m in enumerate(methods or []):
        overrides[f"robots[{i}].method"] = m
    scenario = load_scenario("4r-case1", overrides)
    rngs, _ = trial_generators(0, scenario.n_robots)
    return scenario, make_team(scenario, "nod", rngs)


def test_the_setting_reaches_the_controller():
    view = SimpleNamespace(positions=np.zeros((4, 2)), velocities=np.zeros((4, 2)), age=None)
    for mode in CONVENTIONS:
        _, method = _method(mode)
        partners = method._partners(1, 0.0, view)
        assert partners.robot == 1 and CONVENTIONS[partners.convention] == mode and partners.seen.all()
    _, method = _method("none")
    assert method._partners(0, 0.0, view) is None


def test_only_robots_seen_now_and_people_do_not_keep_the_rule():
    _, method = _method("speed")
    view = SimpleNamespace(positions=np.zeros((4, 2)), velocities=np.zeros((4, 2)),
                           age=np.array([0.0, 0.0, np.inf, 0.3]))
    assert method._partners(0, 0.0, view).seen.tolist() == [True, True, False, False]
    _, team = _method("speed", ["nod", "nod", "person", "nod"])
    assert team.members["nod"].keeps_rule.tolist() == [True, True, False, True]


def test_robots_standing_still_take_turns_one_opinion_period_each():
    scenario, method = _method("speed")
    view = SimpleNamespace(positions=np.zeros((4, 2)), velocities=np.zeros((4, 2)), age=None)
    period = scenario.opinion.T
    assert [method._partners(0, k * period + 0.5 * period, view).turn for k in range(4)] == [0, 1, 0, 1]


def test_stopping_reads_every_robots_own_deceleration():
    """``stopping`` compares |v| / a with each robot's own ``max_accel``: the partners carry them."""
    overrides = {"execution.mutual_braking": "stopping", "robots[2].max_accel": 0.5}
    scenario = load_scenario("4r-case1", overrides)
    rngs, _ = trial_generators(0, scenario.n_robots)
    method = make_team(scenario, "nod", rngs)
    view = SimpleNamespace(positions=np.zeros((4, 2)), velocities=np.zeros((4, 2)), age=None)
    partners = method._partners(0, 0.0, view)
    assert CONVENTIONS[partners.convention] == "stopping"
    assert partners.decels.tolist() == [r.max_accel for r in scenario.robots] and partners.decels[2] == 0.5
    assert partners.dt == scenario.controller.dt


def test_margins_keep_the_restart_gap_from_robots_that_keep_the_rule():
    """From a robot that keeps the rule: 1.55 max(a_i, a_j) dt^2 (the restart gap) plus the check
    headroom (1e-4 m) where that exceeds the safety margin (0.0311 m at 2 m/s^2 and 0.1 s); from a person,
    or with the setting off or without mutual braking, the safety margin alone."""
    overrides = {"robots[2].max_accel": 0.5, "robots[3].method": "person"}
    scenario = load_scenario("4r-case1", overrides)
    rngs, _ = trial_generators(0, scenario.n_robots)
    nod = make_team(scenario, "nod", rngs).members["nod"]
    safety, tol = scenario.controller.safety_margin, RESTART_HEADROOM
    # Robot 2 (0.5 m/s^2) towards robots 0, 1 (2 m/s^2, the larger) and 3 (a person): three predictions each.
    margins = nod._margins_of(2).reshape(3, -1)
    np.testing.assert_allclose(margins, np.tile([0.031 + tol, 0.031 + tol, safety], (3, 1)))
    # Robot 0 towards 1 (2 m/s^2), 2 (0.5 m/s^2: the gap of the harder braker, robot 0) and 3.
    np.testing.assert_allclose(nod._margins_of(0).reshape(3, -1), np.tile([0.031 + tol, 0.031 + tol, safety], (3, 1)))
    slow = load_scenario("4r-case1", {f"robots[{i}].max_accel": 0.5 for i in range(4)})
    # 1.55 * 0.5 * 0.01 = 0.00775 m: below the safety margin, which is kept (the controller's own).
    assert make_team(slow, "nod", rngs)._margins_of(0) is None
    for off in ({"execution.restart_gap": False}, {"execution.mutual_braking": "none"}):
        plain = load_scenario("4r-case1", off)
        assert make_team(plain, "nod", trial_generators(0, 4)[0])._margins_of(0) is None
