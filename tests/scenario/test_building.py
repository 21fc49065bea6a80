"""The building family (random floor plans): valid by construction for many seeds, checked with
shapely from the scenario's numbers (not with the package's own checks); deterministic per seed;
its maps round-trip through scenario/maps.py; bad input is one line, exit code 2. No trial is
simulated here."""

from __future__ import annotations

import math
import os
from collections import deque
from pathlib import Path

import numpy as np
import pytest
import shapely
import yaml

from nodnav.cli import main
from nodnav.scenario.building_check import check_building
from nodnav.scenario.building_map import write_building
from nodnav.scenario.draws import draw, draw_building
from nodnav.scenario.families import FamilyError, family_from_dict, load_family
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.maps import read_map

ROOT = Path(__file__).parents[2]
EXAMPLES = ROOT / "examples" / "building"
SHARED = Path(os.environ.get("NODNAV_SHARED_MAPS", ROOT / ".." / "shared" / "maps"))
SEEDS = range(1, 61)


@pytest.fixture(scope="module")
def plans():
    family = load_family("building")
    return [draw_building(family, s) for s in SEEDS]


# -- independent geometry, with shapely -----------------------------------------------------------


def walls_of(mapping):
    """The walls (polygons) and the building's free space."""
    world = mapping["world"]
    walls = shapely.union_all([shapely.Polygon(o) for o in world["obstacles"]])
    return walls, shapely.box(*world["bounds"]).difference(walls)


def rectangle(p):
    """A passage's clear rectangle from its mouths and width, by hand."""
    a, b = np.array(p["from"]), np.array(p["to"])
    u = (b - a) / np.linalg.norm(b - a)
    n = np.array([-u[1], u[0]]) * p["width"] / 2
    return shapely.Polygon([a - n, b - n, b + n, a + n])


def rooms_crossed(mapping):
    """For each robot, the fewest passages between its origin's room and its destination's: rooms are
    the free space with every passage's rectangle (grown by 1 cm) cut out; a passage joins the rooms
    just beyond its two mouths."""
    _, free = walls_of(mapping)
    passages = mapping["world"]["passages"]
    cut = free.difference(shapely.union_all([rectangle(p).buffer(0.01, join_style="mitre") for p in passages]))
    rooms = list(getattr(cut, "geoms", [cut]))

    def room(pt):
        hits = [k for k, g in enumerate(rooms) if g.contains(shapely.Point(pt))]
        assert len(hits) == 1
        return hits[0]

    edges = []
    for p in passages:
        a, b = np.array(p["from"]), np.array(p["to"])
        u = (b - a) / np.linalg.norm(b - a)
        edges.append((room(a - 0.1 * u), room(b + 0.1 * u)))
    out = []
    for r in mapping["robots"]:
        start, goal = room(r["origin"]), room(r["destination"])
        seen, todo = {start: 0}, deque([start])
        while todo:
            x = todo.popleft()
            for e in edges:
                for p, q in (e, e[::-1]):
                    if p == x and q not in seen:
                        seen[q] = seen[x] + 1
                        todo.append(q)
        out.append(seen.get(goal))
    return out


def test_every_draw_is_valid_by_the_rules(plans):
    rooms_seen = set()
    for m in plans:
        walls, free = walls_of(m)
        robots, passages = m["robots"], m["world"]["passages"]
        radii = sorted(r["radius"] for r in robots)
        assert 2 <= len(robots) <= 8 and 1 <= len(passages) <= 3, m["name"]
        for p in passages:  # single file for these robots: the walls beside the centreline
            a, b = np.array(p["from"]), np.array(p["to"])
            line = [a + t * (b - a) for t in np.linspace(0, 1, 41)]
            gap = 2 * min(walls.boundary.distance(shapely.Point(q)) for q in line)
            assert 2 * radii[-1] + 0.1 - 0.002 <= gap < 2 * (radii[0] + radii[1]), m["name"]
            assert abs(gap - p["width"]) <= 0.002
        shapes = [rectangle(p) for p in passages]
        for i in range(len(shapes)):
            for j in range(i + 1, len(shapes)):
                assert not shapes[i].intersects(shapes[j]), m["name"]
        spots = [(q, r["radius"]) for r in robots for q in (r["origin"], r["destination"])]
        for q, r in spots:  # inside the building, clear of every wall by r + 5 cm
            pt = shapely.Point(q)
            assert free.contains(pt) and free.boundary.distance(pt) >= r + 0.05 - 1e-9, m["name"]
            assert all(abs(v * 1000 - round(v * 1000)) < 1e-6 for v in q)
        for k in range(len(spots)):
            for j in range(k + 1, len(spots)):
                if k // 2 != j // 2:
                    gap = math.dist(spots[k][0], spots[j][0]) - spots[k][1] - spots[j][1]
                    assert gap >= 0.05 - 1e-9, m["name"]
        crossed = rooms_crossed(m)
        said = [int(c) for c in m["description"].split("routes crossing ")[1].split(", ")]
        assert crossed == said, m["name"]
        assert all(1 <= c <= len(passages) for c in crossed)
        rooms_seen.add(len(passages))
    assert rooms_seen == {1, 2, 3}  # the seeds cover every number of passages


def test_draws_pass_the_witness_and_are_deterministic(plans):
    family = load_family("building")
    for s, m in zip(SEEDS[:10], plans):
        assert check_building(m).ok
        assert draw_building(family, s) == m


def test_draws_are_the_same_in_another_interpreter():
    import json
    import subprocess
    import sys

    code = ("import json; from nodnav.scenario.draws import draw_building; "
            "from nodnav.scenario.families import load_family; "
            "print(json.dumps([draw_building(load_family('building'), s) for s in (2, 8)]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONHASHSEED": "54321", "PATH": ""}).stdout
    here = [draw_building(load_family("building"), s) for s in (2, 8)]
    assert json.loads(out) == json.loads(json.dumps(here))


def test_draws_with_several_passages_load_as_drawn_and_one_door_draws_load():
    family = load_family("building")
    several = next(s for s in SEEDS if len(draw_building(family, s)["world"]["passages"]) > 1)
    drawn = draw_building(family, several)["world"]["passages"]
    scenario = draw(family, several)
    assert len(scenario.world.passages) == len(drawn) > 1
    one = load_family("building-one-door")
    for s in range(1, 16):
        scenario = draw(one, s)
        assert len(scenario.world.passages) == 1 and scenario.name == f"building-one-door:{s}"
        assert load_scenario(f"building-one-door:{s}") == scenario


def test_the_one_passage_knob_restricts_every_draw():
    f = family_from_dict({"family": "mine", "building": {"doors": 1}}, "mine.yaml")
    assert f.crossings == (1, 3) and f.doors == (1, 1)
    for s in range(1, 11):
        m = draw_building(f, s)
        assert len(m["world"]["passages"]) == 1 and set(rooms_crossed(m)) == {1}


def test_the_written_map_has_the_plans_walls_within_a_cell(tmp_path):
    family = load_family("building")
    for seed, resolution in ((2, 0.02), (5, 0.05)):
        m = draw_building(family, seed)
        map_path, scenario_path = write_building(m, tmp_path / f"plan{seed}.yaml", resolution=resolution)
        grid = read_map(map_path)
        walls, free = walls_of(m)
        x0, y0, x1, y1 = m["world"]["bounds"]
        assert grid.bounds[:2] == pytest.approx((x0, y0))
        assert 0 <= grid.bounds[2] - x1 < resolution and 0 <= grid.bounds[3] - y1 < resolution
        pts = np.random.default_rng(seed).uniform((x0, y0), (x1, y1), (3000, 2))
        i, j = grid.cell_of(pts)
        half_diagonal = resolution * math.sqrt(0.5)
        for p, cell_free in zip(pts, grid.free[i, j]):
            pt = shapely.Point(p)
            depth = free.boundary.distance(pt)
            if depth > half_diagonal + 1e-9:  # farther than half a cell diagonal from any face
                assert cell_free == free.contains(pt)
        raw = yaml.safe_load(scenario_path.read_text())
        assert raw["world"] == {"map": map_path.name, "passages": m["world"]["passages"]}
        assert raw["robots"] == m["robots"]


def test_a_one_door_map_scenario_loads_with_its_passage(tmp_path):
    m = draw_building(load_family("building-one-door"), 3)
    _, scenario_path = write_building(m, tmp_path / "maps" / "one.yaml", tmp_path / "scenarios")
    s = load_scenario(str(scenario_path))
    g = m["world"]["passages"][0]
    assert s.world.passage.start == tuple(g["from"]) and s.world.passage.width == g["width"]
    assert s.world.map_walls > 0


def test_the_shipped_examples_are_what_nodnav_writes(tmp_path):
    for family, seed, name, scenario in (("building", 218, "two_doors", "building-218"),
                                         ("building-one-door", 8, "one_door", "building-one-door-8")):
        assert main(["generate", family, "--seed", str(seed), "--map", str(tmp_path / f"{name}.yaml"),
                     "--resolution", "0.05"]) == 0
        for file in (f"{name}.yaml", f"{name}.pgm", f"{scenario}.yaml"):
            assert (tmp_path / file).read_bytes() == (EXAMPLES / file).read_bytes(), file
    two = yaml.safe_load((EXAMPLES / "building-218.yaml").read_text())
    assert 4 <= len(two["robots"]) <= 6 and len(two["world"]["passages"]) == 2
    assert rooms_crossed({**two, "world": draw_building(load_family("building"), 218)["world"]}) == [2] * 4


@pytest.mark.parametrize("args, message", [
    (["generate", "mixed", "--map", "x.yaml"], "--map: family 'mixed' draws a corridor"),
    (["generate", "building", "--map", "x.pgm"], "--map: the map's file is a map_server YAML"),
    (["generate", "building", "--map", "x.yaml", "--count", "2"], "--count: --map writes one floor plan"),
    (["generate", "building", "--resolution", "0.05", "--out", "d"], "--resolution: applies to a floor plan"),
    (["generate", "building", "--map", "x.yaml", "--resolution", "0.5"], "--resolution: expected metres per cell"),
    (["generate", "building", "--map", "x.yaml", "--seed", "2", "--resolution", "0.1"], "give a finer --resolution"),
    (["generate", "building"], "--out: give the directory"),
])
def test_bad_generate_input_is_one_line(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1


@pytest.mark.parametrize("building, message", [
    ({"dors": 2}, "building: unknown key 'dors'; did you mean 'doors'?"),
    ({"doors": 4}, "building.doors: expected a whole number or [low, high] in 1..3"),
    ({"doors": [2, 1]}, "building.doors: low 2 is above high 1"),
    ({"doors": 1, "crossings": 2}, "building.crossings: routes cross at least 2 passages"),
    ({"tilt": [-50, 10]}, "building.tilt: expected a number (degrees) in [-45, 45]"),
])
def test_bad_building_family_is_one_line(building, message):
    with pytest.raises(FamilyError, match=None) as info:
        family_from_dict({"family": "b", "building": building}, "b.yaml")
    assert message in str(info.value) and "\n" not in str(info.value)


def test_bad_building_settings_are_one_line():
    with pytest.raises(FamilyError) as info:
        family_from_dict({"family": "b", "building": {}, "scenario": {"game_players": 9}}, "b.yaml")
    assert str(info.value).startswith("b.yaml: scenario.game_players") and "\n" not in str(info.value)


def test_the_queue_scenarios_on_the_public_maps_load():
    if not SHARED.is_dir():
        pytest.skip(f"the public maps are not at {SHARED}")
    for path in sorted(EXAMPLES.glob("*-queues.yaml")):
        text = path.read_text().replace("../../../shared/maps", str(SHARED.resolve()))
        raw = yaml.safe_load(text)
        from nodnav.scenario.schema import scenario_from_dict

        s = scenario_from_dict(raw, path.stem)
        assert s.n_robots >= 3 and len(s.world.passages) == 1


def test_show_draws_a_plan_with_several_passages(tmp_path):
    assert len(draw_building(load_family("building"), 2)["world"]["passages"]) == 2
    out = tmp_path / "g.png"
    assert main(["show", "building", "--seed", "2", "--count", "1", "--out", str(out)]) == 0
    assert out.stat().st_size > 10_000
