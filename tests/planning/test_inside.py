"""Robots that meet inside the passage (issue 19): which orders history still allows, bays found
from the walls, and the fast planner planning back-outs and bays; against hand computations."""

import numpy as np
import pytest

from nodnav.planning.base import PlanRequest, feasible_order
from nodnav.planning.prioritized import PrioritizedPlanner
from nodnav.planning.waiting_spots import bay_spots
from nodnav.scenario.params import FastPlannerParams
from nodnav.scenario.world import Corridor, World


def passage(length: float = 4.0, width: float = 0.4, bay: tuple | None = None) -> World:
    """A passage of ``length`` along x centred at 0, ``width`` wide, 3 m of room at each end; ``bay``
    ``(x0, x1, depth)`` cuts a niche into the upper wall."""
    h, half = 0.5 * width, 0.5 * length
    upper = [(-half, h, half, 3.0)]
    if bay is not None:
        x0, x1, depth = bay
        upper = [(-half, h, x0, 3.0), (x1, h, half, 3.0), (x0, h + depth, x1, 3.0)]
    return World(bounds=(-half - 3.0, -3.0, half + 3.0, 3.0), obstacles=((-half, -3.0, half, -h), *upper),
                 corridor=Corridor(-half, half, -h, h), entrances=((-half, 0.0), (half, 0.0)))


def test_literal_keeps_the_entry_order():
    assert feasible_order((1, 0), (0, 1)) == (0, 1)
    assert feasible_order((2, 1, 0), (0, 1)) == (0, 1, 2)


def test_back_out_frees_only_robots_heading_opposite_ways():
    dirs = np.array([1, -1, 1, -1, 0])
    # 0 and 1 inside heading opposite ways: either may go first.
    assert feasible_order((1, 0), (0, 1), dirs[:2]) == (1, 0)
    assert feasible_order((0, 1), (0, 1), dirs[:2]) == (0, 1)
    # 0 and 2 inside heading the same way (0 entered first): 2 cannot pass 0, whatever is asked.
    assert feasible_order((2, 1, 0), (0, 2, 1), dirs[:3]) == (0, 1, 2)
    assert feasible_order((1, 2, 0), (0, 2, 1), dirs[:3]) == (1, 0, 2)
    # 4 has crossed (direction 0): it stays first; 3 has not entered: after every entered robot.
    assert feasible_order((3, 1, 0, 4), (4, 0, 1), dirs) == (4, 1, 0, 3)


def test_bay_found_from_the_walls():
    # A niche 0.6 m long, 0.5 m deep above a 0.4 m passage: a robot of radius 0.18 keeping 0.19 m
    # from the walls fits where |x| <= 0.3 - 0.19 and 0.2 + 0.18 <= y <= 0.7 - 0.19 (deepest: y = 0.51).
    spots = bay_spots(passage(bay=(-0.3, 0.3, 0.5)), 0.18, 0.19)
    assert spots.shape == (1, 2)
    x, y = spots[0]
    assert abs(x) <= 0.11 + 1e-9 and 0.38 - 1e-9 <= y <= 0.51 + 1e-9
    assert y > 0.51 - 0.05 - 1e-9  # as deep as the sampling step allows
    assert bay_spots(passage(), 0.18, 0.19).shape == (0, 2)  # a plain passage has none
    assert bay_spots(passage(bay=(-0.15, 0.15, 0.5)), 0.18, 0.19).shape == (0, 2)  # too short a niche


def test_on_line_tells_the_bay_from_the_line():
    world = passage(bay=(-0.3, 0.3, 0.5))
    pts = np.array([[0.0, 0.0], [0.0, 0.45], [3.0, 0.0], [0.0, 0.25]])
    assert world.on_line(pts).tolist() == [True, False, False, False]
    assert world.on_line(pts, reach=0.18).tolist() == [True, False, False, True]


def request(world: World, origins, destinations, order) -> PlanRequest:
    n = len(origins)
    return PlanRequest(world=world, positions=np.array(origins, float), velocities=np.zeros((n, 2)),
                       destinations=np.array(destinations, float), radii=np.full(n, 0.18),
                       max_speeds=np.full(n, 0.8), order=order, entered=(0, 1))


@pytest.mark.parametrize("first", [0, 1])
def test_either_robot_inside_may_go_first_and_the_other_backs_out(first):
    world = passage()
    planner = PrioritizedPlanner(world, FastPlannerParams())
    order = (first, 1 - first)
    result = planner.plan(request(world, [[-1.0, 0.0], [1.0, 0.0]], [[4.0, 0.5], [-4.0, -0.5]], order))
    assert result.success, result.reason
    assert result.order_planned == order
    second = 1 - first
    path = result.trajectory.positions[:, second]
    # The second robot first moves away from its goal, out through its own mouth (x = -2 for
    # robot 0, heading right; x = 2 for robot 1, heading left) ...
    heading = 1 if second == 0 else -1
    assert (path[:, 0] * heading).min() < -2.0
    # ... and reaches its goal after the first robot has left the passage.
    assert np.linalg.norm(path[-1] - [[4.0, 0.5], [-4.0, -0.5]][second]) < 1e-6


def test_literal_plans_the_entry_order():
    world = passage()
    planner = PrioritizedPlanner(world, FastPlannerParams(inside="literal"))
    result = planner.plan(request(world, [[-1.0, 0.0], [1.0, 0.0]], [[4.0, 0.5], [-4.0, -0.5]], (1, 0)))
    assert result.success and result.order_planned == (0, 1) and result.repaired


def test_a_robot_ducks_into_a_bay_nearer_than_its_mouth():
    world = passage(length=10.0, bay=(-0.3, 0.3, 0.5))
    planner = PrioritizedPlanner(world, FastPlannerParams())
    result = planner.plan(request(world, [[-1.2, 0.0], [1.2, 0.0]], [[7.0, 0.5], [-7.0, -0.5]], (1, 0)))
    assert result.success, result.reason
    waiting = result.trajectory.positions[:, 0]
    # Robot 0 waits in the bay (off the line: y >= 0.2 + 0.18) and never backs out of the passage.
    assert waiting[:, 1].max() >= 0.38 - 1e-9
    assert waiting[:, 0].min() > -5.0
    # Robot 1 passes on the line, keeping the separation from the robot in the bay.
    gaps = np.linalg.norm(result.trajectory.positions[:, 0] - result.trajectory.positions[:, 1], axis=1)
    assert gaps.min() >= 0.36


def test_eq4_reads_a_robot_backing_out_as_choosing_to_go_second():
    # Robot 1 (heading left) is seen doing what the order (0, 1) has it do: back out. Eq. (4)
    # must then score (0, 1) above (1, 0) for robot 1, and the other way round when it presses on.
    from nodnav.decision.estimation import estimate_social_term, estimated_opinions

    world = passage()
    planner = PrioritizedPlanner(world, FastPlannerParams())
    plans = [planner.plan(request(world, [[-1.0, 0.0], [1.0, 0.0]], [[4.0, 0.5], [-4.0, -0.5]], order))
             for order in ((0, 1), (1, 0))]
    assert all(p.success for p in plans)
    times = np.linspace(0.0, 1.0, 11)

    def states(plan):  # robot 1's planned states over the first second, (1, M, 4)
        t = plan.trajectory
        return np.concatenate([t.positions_at(times), t.velocities_at(times)], axis=-1)[:, 1][None]

    planned = np.stack([states(p) for p in plans])  # (2 orders, 1 robot, M, 4)
    # The two plans differ for robot 1: it backs out (right) under (0, 1) and drives left under (1, 0).
    assert planned[0, 0, -1, 0] > 1.0 > planned[1, 0, -1, 0]
    for seen, favoured in ((0, 0), (1, 1)):
        r = estimate_social_term(estimated_opinions(planned[seen], planned, 0.1))
        assert np.argmax(r[0]) == favoured
