"""Validity and solvability rules on hand-made scenarios whose answer is known by inspection."""

import pytest

from nodnav.scenario.files import builtin_names
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict
from nodnav.scenario.solvable import check_scenario
from nodnav.scenario.validity import check_capacity, check_layout, find_witness, single_file_interval


def scenario(robots, **world):
    """The paper's world (corridor x in [-3, 3], 0.7 m wide, rooms 4 x 5 m), robots of radius 0.2 m."""
    data = {"name": "t", "robots": [{"origin": list(o), "destination": list(d)} for o, d in robots]}
    if world:
        data["world"] = world
    return scenario_from_dict(data)


def test_single_file_interval_by_hand():
    assert single_file_interval([0.2, 0.2]) == pytest.approx((0.5, 0.75))
    # Fits the largest (2 x 0.25 + 0.1); two smallest abreast need 0.7, so at most 0.65.
    assert single_file_interval([0.25, 0.15, 0.2]) == pytest.approx((0.6, 0.65))


def test_builtin_scenarios_are_valid_and_solvable():
    for name in builtin_names():
        verdict = check_scenario(load_scenario(name))
        assert verdict.ok, (name, verdict.reason)


def test_one_blocker_must_be_last_through_its_mouth():
    # Robot 1 parks 10 cm outside the left mouth (its body spans x in [-3.5, -3.1]): nobody can
    # come out of that mouth past it, so robot 2 must cross first.
    s = scenario([((5.0, 1.0), (-3.3, 0.0)), ((5.0, -1.0), (-6.0, 0.0))])
    verdict = find_witness(s)
    assert verdict.ok and verdict.order == (1, 0)


def test_two_blockers_at_different_mouths_are_unsolvable():
    s = scenario([((5.0, 1.0), (-3.3, 0.0)), ((-5.0, 1.0), (3.3, 0.0))])
    assert check_layout(s).ok
    verdict = check_scenario(s)
    assert not verdict.ok and "no order" in verdict.reason


def test_robots_inside_that_would_have_to_pass_each_other_need_a_back_out():
    # Issue 19: facing each other inside, one of them backs out first (the witness says who and
    # where); apart, nobody needs to.
    facing = scenario([((1.0, 0.0), (-6.0, 1.0)), ((-1.0, 0.0), (6.0, 1.0))])
    assert not find_witness(facing).ok
    verdict = check_scenario(facing)
    assert verdict.ok and len(verdict.waits) == 1
    robot, (x, _) = verdict.waits[0]
    # Robot 0 (heading left) backs out right, or robot 1 (heading right) backs out left, beyond its mouth.
    assert (robot, x > 3.0) in ((0, True), (1, False)) and abs(x) > 3.0
    apart = scenario([((-1.0, 0.0), (-6.0, 1.0)), ((1.0, 0.0), (6.0, 1.0))])
    assert check_scenario(apart).ok and not check_scenario(apart).waits


def test_blocker_with_a_robot_inside_heading_the_other_way_backs_out_the_other_side():
    # Robot 1 is inside heading right and will park right outside the right mouth; robot 2 is
    # inside between it and that mouth, heading left. Robot 2 backing out right could never come
    # back in; robot 1 backing out left lets robot 2 through, and then parks.
    s = scenario([((-1.0, 0.0), (3.3, 0.0)), ((1.0, 0.0), (-6.0, 0.0))])
    verdict = check_scenario(s)
    assert verdict.ok and verdict.waits[0][0] == 0 and verdict.waits[0][1][0] < -3.0
    assert verdict.order == (1, 0)


def test_two_blockers_inside_at_opposite_mouths_are_rejected():
    # Each parks right outside the mouth the other must leave by: whoever backs out can never
    # come back in past the other's parked body.
    s = scenario([((-1.0, 0.0), (3.3, 0.0)), ((1.0, 0.0), (-3.3, 0.0))])
    assert not check_scenario(s).ok


def test_robots_waiting_at_both_mouths_step_aside():
    s = scenario([((-3.25, 0.0), (6.0, 1.0)), ((3.25, 0.0), (-6.0, -1.0))])
    verdict = check_scenario(s)
    assert verdict.ok and verdict.waits  # someone had to clear a mouth first
    for _robot, (x, y) in verdict.waits:
        mouth = (-3.0 if x < 0 else 3.0, 0.0)
        assert ((x - mouth[0]) ** 2 + (y - mouth[1]) ** 2) ** 0.5 >= 0.35 + 0.4 + 0.1 + 0.2 - 1e-9


def test_layout_rules_name_what_is_wrong():
    wide = scenario([((-5.0, 1.0), (5.0, 1.0)), ((5.0, -1.0), (-5.0, -1.0))], corridor_width=0.9)
    assert "single-file interval" in check_layout(wide).reason
    near_wall = scenario([((-6.78, 1.0), (5.0, 1.0)), ((5.0, -1.0), (-5.0, -1.0))])
    assert "from a wall" in check_layout(near_wall).reason  # 0.02 m beyond its radius
    on_destination = scenario([((-5.0, 1.0), (5.0, 1.0)), ((5.3, 1.1), (-5.0, -1.0))])
    assert "robots 1 and 2 stand" in check_layout(on_destination).reason
    same_side = scenario([((-5.0, 1.0), (-5.0, -1.0)), ((5.0, -1.0), (-4.0, 1.0))])
    assert "does not cross" in check_layout(same_side).reason


def test_small_rooms_fail_the_capacity_rule():
    # Rooms 1.2 m deep: depth must be at least rho + 2 r + 2c = (0.35 + 0.4 + 0.1) + 0.4 + 0.1 = 1.35 m.
    s = scenario([((-3.5, 0.5), (3.5, 0.5)), ((3.5, -0.5), (-3.5, -0.5))], bounds=[-4.2, -2.5, 4.2, 2.5])
    assert check_layout(s).ok
    verdict = check_capacity(s)
    assert not verdict.ok and "needs depth 1.35 m" in verdict.reason
