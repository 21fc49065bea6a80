"""Controllers of robots with the same body share their MPC setup and problems (control/mpc.py):
a controller's results must not depend on what the others sharing them did in between."""

import numpy as np

from nodnav.control import ControlRequest
from nodnav.control.mpc import BSplineMPC, SharedSetups
from nodnav.scenario.loading import load_scenario


def _requests(scenario, robot, other):
    """A closed loop of ``robot``'s controller alone, heading for its destination past ``other``
    standing still: the requests it was given and its results."""
    c = scenario.controller
    times = c.horizon * np.arange(1, c.samples + 1) / c.samples
    spec = scenario.robots[robot]
    p, v = np.array(spec.origin, dtype=float), np.zeros(2)
    goal = np.array(spec.destination, dtype=float)
    still = np.repeat(np.array(scenario.robots[other].origin, dtype=float)[None, None], len(times), axis=1)
    return p, v, goal, times, np.repeat(still, 3, axis=0), np.full(3, scenario.robots[other].radius)


def _run(controller, start, steps, interleave=None):
    p, v, goal, times, others, radii = start
    out = []
    for k in range(steps):
        heading = (goal - p) / max(np.linalg.norm(goal - p), 1e-9)
        reference = p + np.minimum(times[:, None] * 1.0, np.linalg.norm(goal - p)) * heading
        res = controller.control(ControlRequest(position=p, velocity=v, reference=reference, sample_times=times,
                                                others=others, other_radii=radii, firm=np.array([False, False, True])))
        out.append(np.concatenate([res.next_position, res.next_velocity, res.planned_positions.ravel()]))
        p, v = res.next_position, res.next_velocity
        if interleave is not None:
            interleave(k)
    return np.array(out)


def test_controllers_sharing_a_setup_do_not_disturb_each_other():
    s = load_scenario("4r-case2")
    assert s.robots[0].radius == s.robots[2].radius and s.robots[0].max_accel == s.robots[2].max_accel
    first = _requests(s, 0, 1)
    alone = _run(BSplineMPC(s.world, s.robots[0], s.controller), first, 40)

    shared = SharedSetups()
    mine = BSplineMPC(s.world, s.robots[0], s.controller, shared)
    theirs = BSplineMPC(s.world, s.robots[2], s.controller, shared)
    assert mine.setup is theirs.setup  # one setup for the same world, body and parameters
    second = _requests(s, 2, 3)
    state = {"p": second[0], "v": second[1]}

    def step_theirs(k):
        # The other controller steps in between, writing the shared rows for its own problem.
        res = _run(theirs, (state["p"], state["v"], *second[2:]), 1)[0]
        state["p"], state["v"] = res[:2], res[2:4]

    together = _run(mine, first, 40, interleave=step_theirs)
    assert np.linalg.norm(alone[-1, :2] - first[0]) > 1.0  # it moved
    assert alone.tobytes() == together.tobytes()
