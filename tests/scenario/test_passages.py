"""Passages at any angle and polygon walls in scenarios: the passage's frame, loading, and the
one-line errors of bad input (issue 20, items 1, 2 and 7's passage errors)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from nodnav.cli import main
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict
from nodnav.scenario.world import INSIDE, LEFT, RIGHT, Passage, paper_world

#: The issue's reproducer: the paper's head-on pair turned by 90 degrees, corridor along y.
TURNED = {
    "world": {"bounds": [-2.5, -7.0, 2.5, 7.0],
              "obstacles": [[-2.5, -3.0, -0.35, 3.0], [[0.35, -3.0], [2.5, -3.0], [2.5, 3.0], [0.35, 3.0]]],
              "passages": [{"from": [0.0, -3.0], "to": [0.0, 3.0], "width": 0.7}]},
    "robots": [{"origin": [0.0, -5.5], "destination": [-1.2, 5.5]},
               {"origin": [0.0, 5.5], "destination": [1.2, -5.5]}],
}


def turned(**world):
    raw = yaml.safe_load(yaml.safe_dump(TURNED))
    raw["world"].update(world)
    return raw


def error(raw) -> str:
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(raw)
    text = str(info.value)
    assert "\n" not in text
    return text


def test_the_paper_corridor_frame_is_raw_x_bit_for_bit():
    world = paper_world()
    g = world.passage
    assert g.along_x and g.angle == 0.0 and (g.s_start, g.s_end, g.t_centre) == (-3.0, 3.0, 0.0)
    pts = np.random.default_rng(0).uniform(-8.0, 8.0, size=(1000, 2))
    pts[:10, 0] = [-3.0, 3.0, np.nextafter(-3.0, 0), np.nextafter(3.0, 0), np.nextafter(-3.0, -9), 0.0, -0.0, 1, 2, 3]
    assert np.array_equal(world.along(pts), pts[:, 0])
    x = pts[:, 0]
    assert np.array_equal(world.side_of(pts), np.where(x < -3.0, LEFT, np.where(x > 3.0, RIGHT, INSIDE)))


def test_a_passage_along_y_has_its_own_sides_and_distances():
    s = scenario_from_dict(TURNED)
    w = s.world
    assert w.corridor is None and w.entrances == ((0.0, -3.0), (0.0, 3.0))
    g = w.passage
    assert g.axis == (0.0, 1.0) and g.normal == (-1.0, 0.0) and g.length == 6.0
    pts = np.array([[0.0, -5.5], [0.1, 0.0], [0.0, 5.5], [3.0, -3.0]])
    assert w.side_of(pts).tolist() == [LEFT, INSIDE, RIGHT, INSIDE]
    # eq. (6): distance to the entrance on the approach side, zero once inside
    d = w.corridor_distance(pts[:3], np.array([LEFT, LEFT, RIGHT]))
    assert d.tolist() == [2.5, 0.0, 2.5]
    assert w.clearance(np.array([[0.0, 0.0]]))[0] == pytest.approx(0.35)


def test_a_passage_at_30_degrees_frame():
    a = math.radians(30.0)
    g = Passage(start=(1.0, 2.0), end=(1.0 + 4.0 * math.cos(a), 2.0 + 4.0 * math.sin(a)), width=0.7)
    assert g.length == pytest.approx(4.0) and g.angle == pytest.approx(a)
    mid = np.array([1.0 + 2.0 * math.cos(a), 2.0 + 2.0 * math.sin(a)])
    assert g.along(mid) - g.s_start == pytest.approx(2.0)
    assert g.across(mid) == pytest.approx(g.t_centre)
    before, after = np.array(g.start) - 0.1 * np.array(g.axis), np.array(g.end) + 0.1 * np.array(g.axis)
    assert g.side_of_along(g.along(np.array([before, mid, after]))).tolist() == [LEFT, INSIDE, RIGHT]
    np.testing.assert_allclose(g.to_world(g.along(mid), g.across(mid)), mid, atol=1e-12)


def test_passages_and_polygons_survive_the_round_trip():
    s = scenario_from_dict(TURNED)
    back = scenario_from_dict(scenario_to_dict(s))
    assert back.world == s.world and back.world.polygons == s.world.polygons


def test_a_builtin_keeps_its_shorthand_text():
    raw = scenario_to_dict(load_scenario("3r-case4"))["world"]
    assert set(raw) == {"bounds", "obstacles", "corridor", "entrances"}


@pytest.mark.parametrize("world, words", [
    ({"obstacles": [[[0, 0], [1, 1]]]}, "world.obstacles[0]: a polygon needs at least 3 points"),
    ({"obstacles": [[[3, 3], [4, 4], [4, 3], [3, 4]]]}, "world.obstacles[0]: the polygon crosses itself"),
    ({"obstacles": [[[3, 3], [4, 4], [5, 5]]]}, "world.obstacles[0]: the polygon has zero area"),
    ({"passages": [{"from": [0, -3], "to": [0, 3], "width": 0.7}, {"from": [0.2, -3], "to": [0.2, 3], "width": 0.7}]},
     "world.passages[1]: overlaps world.passages[0]"),
    ({"passages": [{"from": [0, -3], "to": [0, -3], "width": 0.7}]}, "its two mouths are the same point"),
    ({"passages": [{"from": [0, -3], "to": [0, 3]}]}, "missing key 'width'"),
    ({"passages": [{"from": [0, -3], "to": [0, 9], "width": 0.7}]}, "world.passages[0].to: [0.0, 9.0] is outside"),
    ({"corridor_width": 0.7}, "give either passages or the paper's corridor shorthand"),
    ({"obstacles": [[-2.5, -3.0, -0.6, 3.0], [0.6, -3.0, 2.5, 3.0]]}, "world.passages[0]: is not single file"),
])
def test_bad_worlds_get_one_line(world, words):
    assert words in error(turned(**world))


def test_the_issue_reproducer_points_to_passages():
    raw = {"world": {"entrances": [[0.0, -3.0], [0.0, 3.0]]}, "robots": TURNED["robots"]}
    assert "world.passages" in error(raw)


def test_bad_polygon_from_the_command_line_exits_2(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(turned(obstacles=[[[3, 3], [4, 4], [4, 3], [3, 4]]])))
    assert main(["show", str(path), "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert "world.obstacles[0]" in err and "\n" not in err


def test_side_of_along_is_the_two_wheres_it_replaced():
    rng = np.random.default_rng(3)
    for g in (paper_world().passage, Passage(start=(1.0, 2.0), end=(-2.0, 5.5), width=0.7)):
        s = rng.uniform(-9.0, 9.0, size=(40, 3))
        s[0, :] = [g.s_start, g.s_end, np.nan]
        s[1, :] = [np.nextafter(g.s_start, -np.inf), np.nextafter(g.s_end, np.inf), -np.inf]
        for shaped in (s, s[0], s[:, 1], s[0, 0], np.asarray(s[0, 1]), s.T, np.zeros((0, 2))):
            want = np.where(shaped < g.s_start, LEFT, np.where(shaped > g.s_end, RIGHT, INSIDE))
            got = g.side_of_along(shaped)
            assert type(got) is type(want) and got.dtype == want.dtype and got.shape == want.shape
            assert np.array_equal(got, want)
