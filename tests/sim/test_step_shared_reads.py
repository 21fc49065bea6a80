"""What the closed loop now reads once per step rather than once per robot, against what it
replaces: a view built positionally is the constructor's, and the braking partners built from a
view's shared fields are those :meth:`PlannedMethod._partners` builds for each robot."""

from dataclasses import fields

import numpy as np

from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import Simulation
from nodnav.sim.views import RobotView


def test_a_view_built_has_the_constructors_fields():
    rng = np.random.default_rng(0)
    states, times = rng.normal(size=(3, 11, 4)), np.linspace(0.0, 1.0, 11)
    for extra in ((), (np.zeros(3), None, ((0,), (1, 2)))):
        args = (1.5, times, states, (2, 0), *extra)
        built, want = RobotView.built(*args), RobotView(*args)
        assert type(built) is RobotView
        assert all(getattr(built, f.name) is getattr(want, f.name) for f in fields(RobotView))


def test_partners_from_a_views_shared_fields_equal_each_robots_own():
    sim = Simulation(load_scenario("4r-case1"), "nod", 1)
    for _ in range(25):
        sim.step()
    method, views = sim.method, sim.views()
    for i, view in views.items():
        shared = method._partners_shared(sim.t, view, view.positions, view.velocities)
        own = method._partners(i, sim.t, view)
        assert own is not None and shared is not None
        assert own.robot == i and len(own) == 1 + len(shared)
        for a, b in zip(own[1:], shared):
            if isinstance(a, np.ndarray):
                assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
            else:
                assert type(a) is type(b) and a == b
