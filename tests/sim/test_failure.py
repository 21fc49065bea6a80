"""Failure classes: the table of the module docstring, and the simulator reporting them."""

import json

import numpy as np
import pytest

from nodnav.scenario.loading import load_scenario
from nodnav.sim.failure import FAILURE_CLASSES, classify, collision_kind, plans_failing_at_end
from nodnav.sim.simulator import Simulation


@pytest.mark.parametrize("outcome, kind, consensus, plans_failing, expected", [
    ("success", "", True, False, "success"),
    ("collision", "robot-robot", True, True, "collision-robot-robot"),
    ("collision", "wall", False, False, "collision-wall"),
    ("deadlock", "", True, False, "jam"),
    ("deadlock", "", False, False, "disagreement"),
    ("deadlock", "", True, True, "plan-failure"),  # no plan: agreement cannot help
    ("timeout", "", False, True, "plan-failure"),
    ("timeout", "", True, False, "timeout"),
    ("error", "", False, False, "error"),
])
def test_classes(outcome, kind, consensus, plans_failing, expected):
    assert classify(outcome, kind, consensus, plans_failing) == expected
    assert expected in FAILURE_CLASSES or expected == "error"


def test_collision_kind_prefers_robots():
    assert (collision_kind(1, 0), collision_kind(0, 2), collision_kind(1, 1), collision_kind(0, 0)) == \
        ("robot-robot", "wall", "robot-robot", "")


def test_plans_failing_only_counts_the_last_decision():
    events = [{"t": 1.0, "kind": "plan", "robot": 0}, {"t": 2.0, "kind": "mpc", "robot": 1}]
    assert plans_failing_at_end(events, [0.0, 1.0])
    assert not plans_failing_at_end(events, [0.0, 1.0, 2.0])  # the plan failure was earlier
    assert not plans_failing_at_end([], [])


def _ended(positions):
    sim = Simulation(load_scenario("2r-case2"), seed=1)
    sim.positions[:] = positions
    sim._judge(np.repeat(sim.positions[None], 4, axis=0))
    return json.loads(json.dumps(sim.result(0.0).to_dict()))


def test_the_summary_names_the_class_and_the_collision_kind():
    # Discs of radius 0.2 with centres 0.3 m apart overlap; a centre 0.05 m from the corridor's
    # wall (y = 0.35) puts the disc in it.
    d = _ended(np.array([[-5.0, 1.5], [-4.7, 1.5]]))
    assert (d["outcome"], d["collision_kind"], d["failure_class"]) == ("collision", "robot-robot",
                                                                       "collision-robot-robot")
    d = _ended(np.array([[0.0, 0.3], [5.0, 1.5]]))
    assert (d["outcome"], d["collision_kind"], d["failure_class"]) == ("collision", "wall", "collision-wall")
