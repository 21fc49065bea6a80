"""The braking invariant (docs/safety.md), checked against an independent reference: the
world's own clearance (:meth:`World.clearance`) on the committed trajectory sampled densely."""

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nodnav.control import ControlRequest
from nodnav.control.braking import segment_clearance, tail_clearance, tail_decel, tail_end
from nodnav.control.mpc import BSplineMPC
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams, RobotSpec
from nodnav.scenario.transform import transform_points, transform_scenario
from nodnav.scenario.world import paper_world

WORLD = paper_world()
#: The paper's world turned by 30 degrees about the origin: its walls are polygons.
TURNED = transform_scenario(load_scenario("2r-case1"), 30.0).world
PARAMS = MPCParams()
TIMES = PARAMS.horizon * np.arange(1, 9) / 8
NO_OTHERS = np.zeros((0, 8, 2))
NO_PIECES = np.zeros((0, 3, 2))


def clear(a, b, boxes, bounds, pieces=NO_PIECES) -> float:
    return segment_clearance(np.array(a, dtype=float), np.array(b, dtype=float), boxes, pieces, bounds)


def test_segment_clearance_by_hand():
    boxes = np.array([[0.0, 0.0, 1.0, 1.0]])
    bounds = np.array([-10.0, -10.0, 10.0, 10.0])
    # Passing above the box at height 2: 1 m from its top face.
    assert clear([-3.0, 2.0], [3.0, 2.0], boxes, bounds) == pytest.approx(1.0)
    # Towards its corner (1, 1) along the diagonal, stopping sqrt(2) short of it.
    assert clear([3.0, 3.0], [2.0, 2.0], boxes, bounds) == pytest.approx(math.sqrt(2))
    # Through the box: negative (half its side inside at the centre).
    assert clear([-1.0, 0.5], [2.0, 0.5], boxes, bounds) == pytest.approx(-0.5)
    # The bounds count at the ends.
    assert clear([5.0, 5.0], [9.5, 5.0], boxes, bounds) == pytest.approx(0.5)


def test_tail_clearance_is_the_stopping_distance_by_hand():
    # 1 m/s towards a wall 3 m ahead at 0.25 m/s^2: stops 2 m on, 1 m short of it.
    boxes = np.array([[3.0, -5.0, 4.0, 5.0]])
    bounds = np.array([-10.0, -10.0, 10.0, 10.0])
    assert tail_clearance(np.zeros(2), np.array([1.0, 0.0]), 0.25, boxes, NO_PIECES, bounds) == pytest.approx(1.0)


def test_clearances_from_a_polygon_wall_by_hand():
    # The unit square turned by 45 degrees about its centre (0, 0): a diamond with corners at
    # distance sqrt(2)/2 on the axes; its faces lie 0.5 from the centre.
    h = math.sqrt(2) / 2
    diamond = np.array([[[h, 0.0], [0.0, h], [-h, 0.0], [0.0, -h]]])
    no_boxes = np.zeros((0, 4))
    bounds = np.array([-10.0, -10.0, 10.0, 10.0])
    # Passing above at height 2: the top corner (0, h) is nearest.
    assert clear([-3.0, 2.0], [3.0, 2.0], no_boxes, bounds, diamond) == pytest.approx(2.0 - h)
    # Towards a face along its normal (1, 1)/sqrt(2), stopping at distance 2 from the centre.
    u = np.array([1.0, 1.0]) / math.sqrt(2)
    assert clear(3.0 * u, 2.0 * u, no_boxes, bounds, diamond) == pytest.approx(1.5)
    # Through it: half the face-to-face width inside at the centre.
    assert clear([-1.0, 0.0], [1.0, 0.0], no_boxes, bounds, diamond) == pytest.approx(-0.5, abs=1e-6)
    # A braking tail along x at 1 m/s, 0.25 m/s^2 from x = -3 stops at x = -1, h - 1 from its corner.
    assert tail_clearance(np.array([-3.0, 0.0]), np.array([1.0, 0.0]), 0.25, no_boxes, diamond,
                          bounds) == pytest.approx(1.0 - h)


def clearance_along(points: np.ndarray, world=WORLD) -> float:
    return float(world.clearance(points).min())


def committed_clearance(ctl: BSplineMPC, robot: RobotSpec, world=WORLD) -> float:
    """Least clearance of the controller's committed trajectory (plan, then braking tail), sampled
    so finely that it moves at most a millimetre between samples (the world's clearance is
    1-Lipschitz), until it has stopped; checks that it does stop."""
    decel = tail_decel(robot.max_accel, PARAMS.terminal_decel, PARAMS.accel_polygon_sides)
    until = PARAMS.horizon + robot.max_speed / decel + 0.05
    times = np.linspace(0.0, until, int(until * robot.max_speed / 1e-3) + 2)
    path = ctl.braking_trajectory(times)
    assert path is not None
    np.testing.assert_allclose(path[-1], path[-2], atol=1e-12)  # at rest in the end
    return clearance_along(path, world)


@st.composite
def robot_states(draw):
    radius = draw(st.floats(0.1, 0.35))
    max_speed = draw(st.floats(0.2, 2.0))
    max_accel = draw(st.floats(0.1, 3.0))
    robot = RobotSpec(origin=(-5.0, 0.0), destination=(5.0, 0.0), radius=radius, max_speed=max_speed,
                      max_accel=max_accel)
    # Near a wall: in the left room by the corridor's wall, or at the corridor's mouth; in the
    # paper's world (box walls) or in the same world turned by 30 degrees (polygon walls).
    turned = draw(st.booleans())
    world, angle = (TURNED, 30.0) if turned else (WORLD, 0.0)
    x = draw(st.floats(-6.8, -2.0))
    y = draw(st.floats(-2.3, 2.3))
    p = transform_points(np.array([x, y]), angle)
    clear = float(world.clearance(p[None])[0])
    speed = draw(st.floats(0.0, 1.0)) * max_speed
    heading = draw(st.floats(-math.pi, math.pi))
    v = speed * np.array([math.cos(heading), math.sin(heading)])
    # The reference: full speed towards a point, often one in or behind a wall.
    target = transform_points(np.array([draw(st.floats(-7.5, 0.0)), draw(st.floats(-3.0, 3.0))]), angle)
    # From this step on another robot is predicted on top of this one: no plan is found, and
    # (without the evasive fallback) the robot must follow its committed trajectory.
    blocked_from = draw(st.integers(1, 14))
    return robot, world, p, v, target, clear, blocked_from


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(robot_states())
def test_every_step_leaves_a_braking_trajectory_clear_of_the_walls(state):
    robot, world, p, v, target, clear, blocked_from = state
    if clear < robot.radius + 1e-3:
        return  # the robot would start in contact: the loader refuses such scenarios
    ctl = BSplineMPC(world, robot, replace(PARAMS, evasive=False))
    had = False
    for k in range(12):
        direction = target - p
        dist = float(np.hypot(*direction))
        step = direction / max(dist, 1e-9) * np.minimum(robot.max_speed * TIMES, dist)[:, None]
        blocked = k >= blocked_from
        others = np.repeat(p[None, None] + 0.01, 8, axis=1) if blocked else NO_OTHERS
        res = ctl.control(ControlRequest(position=p, velocity=v, reference=p + step, sample_times=TIMES,
                                         others=others, other_radii=np.full(len(others), 0.2)))
        moved = clearance_along(np.vstack([p[None], res.step_positions]), world)
        if res.info["fallback"] == "braking":
            # Braking along the velocity where it stops clear of the walls (then the step is
            # clear), else only without a committed trajectory, saying why.
            straight = tail_clearance(p, v, robot.max_accel, world.obstacle_array, world.piece_array,
                                      world.bounds_array)
            # Within the controller's check tolerance of the radius counts as clear (as it does
            # for the controller; a random draw once fell in that 1e-4 m band).
            if straight >= robot.radius - PARAMS.check_tolerance:
                assert "stops clear of the walls" in res.reason and moved >= robot.radius - 1e-3
            else:
                assert not had, res.reason
                assert "no braking trajectory known to be clear" in res.reason
        else:
            # A plan was accepted or the committed one followed: the step and the whole braking
            # trajectory that remains are clear.
            assert res.success or not blocked or res.info["fallback"] == "committed"
            had = True
            assert moved >= robot.radius - 1e-3, res.reason
            assert committed_clearance(ctl, robot, world) >= robot.radius - 1e-3, res.reason
        p, v = res.next_position, res.next_velocity


def test_follows_its_committed_trajectory_where_braking_straight_would_hit_a_wall():
    """A robot turning along the wall towards the corridor: where braking along its velocity would
    reach the wall and no plan is found (another robot predicted on top of it), it follows its
    last plan and that plan's braking tail, and stops clear of the walls."""
    robot = RobotSpec(origin=(-6.0, 2.0), destination=(5.0, 0.0), radius=0.2, max_speed=1.0, max_accel=0.5)
    ctl = BSplineMPC(WORLD, robot, replace(PARAMS, evasive=False))
    corner, down = np.array([-3.25, 2.0]), np.array([0.0, -1.0])
    start = np.array([-6.0, 2.0])

    def reference(t):
        d = t + TIMES
        first = np.linalg.norm(corner - start)
        along = np.minimum(d, first)[:, None] * (corner - start) / first
        return start + along + np.clip(d - first, 0.0, 4.0)[:, None] * down

    p, v, blocked, kinds = start, np.zeros(2), False, []
    for k in range(120):
        straight = tail_clearance(p, v, robot.max_accel, WORLD.obstacle_array, WORLD.piece_array,
                                      WORLD.bounds_array)
        blocked = blocked or straight < robot.radius
        others = np.repeat(p[None, None] + 0.01, 8, axis=1) if blocked else NO_OTHERS
        res = ctl.control(ControlRequest(position=p, velocity=v, reference=reference(0.1 * k), sample_times=TIMES,
                                         others=others, other_radii=np.full(len(others), 0.2)))
        assert clearance_along(np.vstack([p[None], res.step_positions])) >= robot.radius - 1e-6, res.reason
        if blocked:
            kinds.append(res.info["fallback"])
        p, v = res.next_position, res.next_velocity
    assert kinds and kinds[0] == "committed"
    assert np.hypot(*v) < 1e-9 and clearance_along(p[None]) >= robot.radius  # at rest, clear


def test_tail_clearance_is_segment_clearance_of_the_tail_bit_for_bit():
    """The compiled tail_clearance against its plain composition: tail_end, then segment_clearance."""
    world = load_scenario("4r-case2").world
    rng = np.random.default_rng(11)
    for _ in range(200):
        p, v = rng.uniform([-6.0, 0.0], [6.0, 3.0]), rng.normal(0.0, 1.0, 2)
        want = float(segment_clearance(p, tail_end(p, v, 1.2), world.obstacle_array, world.piece_array,
                                       world.bounds_array))
        got = tail_clearance(p, v, 1.2, world.obstacle_array, world.piece_array, world.bounds_array)
        assert np.float64(got).tobytes() == np.float64(want).tobytes()


@pytest.mark.parametrize("seed", range(3))
def test_segment_clearance_examining_the_nearest_walls_is_the_loop_over_all(seed):
    """The tail's clearance skips walls whose bounding box is farther than the least value found:
    the same value, bit for bit, as the minimum over every wall (boxes and polygon pieces),
    for tails that enter walls (negative values) and tails far from all."""
    from nodnav.control.braking import _closest_on_segment
    from nodnav.scenario.polygons import convex_pieces, padded_pieces

    rng = np.random.default_rng(seed)
    bounds = np.array([-5.0, -5.0, 5.0, 5.0])
    lo = rng.uniform(-5.0, 5.0, (200, 2))
    boxes = np.hstack([lo, lo + rng.uniform(0.02, 0.8, (200, 2))])
    triangle = np.array([[0.0, 0.0], [0.5, 0.0], [0.3, 0.4]])
    polys = [c + rng.uniform(-0.4, 0.4) + triangle for c in rng.uniform(-4, 4, (5, 2))]
    pieces = padded_pieces([q for p in polys for q in convex_pieces(p)])
    for _ in range(300):
        a = rng.uniform(-5.0, 5.0, 2)
        b = a + rng.normal(0.0, 1.0, 2)
        want = min(min(a[0] - bounds[0], bounds[2] - a[0], a[1] - bounds[1], bounds[3] - a[1]),
                   min(b[0] - bounds[0], bounds[2] - b[0], b[1] - bounds[1], bounds[3] - b[1]))
        for g in range(len(boxes) + len(pieces)):
            want = min(want, _closest_on_segment(a[0], a[1], b[0], b[1], g, boxes, pieces)[1])
        assert segment_clearance(a, b, boxes, pieces, bounds) == want
