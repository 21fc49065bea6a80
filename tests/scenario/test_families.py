"""Scenario families: determinism, validity of many draws checked from the numbers, file errors,
FAMILY:SEED specs and generated files. No trial is simulated."""

import math

import numpy as np
import pytest
import yaml

from nodnav.cli import main
from nodnav.scenario.draws import draw, draw_generator
from nodnav.scenario.families import FamilyError, builtin_families, family_from_dict, load_family, parse_draw_spec
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_to_dict
from nodnav.sim.simulator import trial_generators

SEEDS = {"mixed": range(1, 241), "paper-like": range(1, 121), "crowded": range(1, 41)}


@pytest.fixture(scope="module")
def draws():
    """Every draw of :data:`SEEDS`, by family (drawn once for the module)."""
    return {name: [draw(load_family(name), s) for s in seeds] for name, seeds in SEEDS.items()}


# -- independent geometry: the rules of scenario/validity.py recomputed from the numbers ------------


def wall_clearance(p, bounds, obstacles):
    """Distance from ``p`` to the box's sides and to the nearest rectangle (by hand, no package code)."""
    x, y = p
    d = min(x - bounds[0], bounds[2] - x, y - bounds[1], bounds[3] - y)
    for x0, y0, x1, y1 in obstacles:
        dx, dy = max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1)
        inside = x0 < x < x1 and y0 < y < y1
        d = min(d, -1.0 if inside else math.hypot(dx, dy))
    return d


def side(x, h):
    return -1 if x < -h else (1 if x > h else 0)


def assert_valid(s):
    w = s.world
    h, half = w.corridor.x_max, w.corridor.y_max
    x0, y0, x1, y1 = w.bounds
    # The layout: a corridor about y = 0, centred on x = 0, through a wall of two blocks.
    assert w.corridor.x_min == -h and w.corridor.y_min == -half
    assert w.obstacles == ((-h, y0, h, -half), (-h, half, h, y1))
    assert w.entrances == ((-h, 0.0), (h, 0.0))
    assert x0 < -h and x1 > h and y0 < -half and y1 > half
    radii = [r.radius for r in s.robots]
    # Single file for every pair, and every robot fits with 5 cm a side.
    a, b = sorted(radii)[:2]
    assert 2 * max(radii) + 0.1 - 1e-9 <= 2 * half <= 2 * (a + b) - 0.05 + 1e-9
    for k, r in enumerate(s.robots):
        for p in (r.origin, r.destination):
            assert wall_clearance(p, w.bounds, w.obstacles) >= r.radius + 0.05 - 1e-9, (s.name, k)
            assert all(abs(v * 1000 - round(v * 1000)) < 1e-6 for v in p)  # millimetres
        start, goal = side(r.origin[0], h), side(r.destination[0], h)
        assert goal != 0 and goal != start, (s.name, k)  # everyone crosses
        if start == 0:
            assert abs(r.origin[1]) <= half - r.radius - 0.05 + 1e-9
        assert 0.15 - 1e-9 <= r.radius <= 0.5 + 1e-9 and 0.2 - 1e-9 <= r.max_speed <= 2.0 + 1e-9
        assert 0.1 - 1e-9 <= r.max_accel <= 3.0 + 1e-9
    # Nobody stands on anybody, wherever robots stand still.
    spots = [(k, p, r.radius) for k, r in enumerate(s.robots) for p in (r.origin, r.destination)]
    for i, (k, p, rp) in enumerate(spots):
        for m, q, rq in spots[i + 1:]:
            if k != m:
                assert math.dist(p, q) >= rp + rq + 0.05 - 1e-9, (s.name, k, m)


def routes(s):
    h = s.world.corridor.x_max
    out = []
    for r in s.robots:
        start, goal = side(r.origin[0], h), side(r.destination[0], h)
        far = (goal * h, 0.0)
        tail = math.dist(r.destination, far)
        out.append(math.dist(r.origin, far) + tail if start == 0 else math.dist(r.origin, (start * h,
                                                                                           0.0)) + 2 * h + tail)
    return out


@pytest.mark.parametrize("name", list(SEEDS))
def test_every_draw_is_valid(draws, name):
    for s in draws[name]:
        assert_valid(s)
        # The time limit's formula, by hand: rest to rest at the speed limit and half the
        # acceleration limit, a trapezoid (or a triangle when the speed is never reached).
        v = [r.max_speed for r in s.robots]
        a = [r.max_accel / 2 for r in s.robots]

        def t(length, speed, accel):
            accelerating = speed / accel  # seconds to reach the speed, and as many to stop
            if speed * accelerating >= length:  # a triangle: half the way up, half down
                return 2 * math.sqrt(length / accel)
            return 2 * accelerating + (length - speed * accelerating) / speed

        L, r_max = 2 * s.world.corridor.x_max, max(r.radius for r in s.robots)
        own = max(t(length, speed, acc) for length, speed, acc in zip(routes(s), v, a))
        limit = math.ceil(20 + 1.5 * (own + sum(t(L + 4 * r_max, x, acc) for x, acc in zip(v, a))))
        assert s.time_limit == limit


def test_mixed_covers_what_the_family_promises(draws):
    seen = {"doorway": 0, "hallway": 0, "inside": 0, "one-sided": 0, "head-on": 0, "mouth": 0, "axis": 0,
            "mixed radii": 0, "mixed speeds": 0, "mixed accelerations": 0, "slow": 0, "queue": 0}
    counts = set()
    for s in draws["mixed"]:
        h = s.world.corridor.x_max
        counts.add(s.n_robots)
        seen["doorway"] += 2 * h < 2.0
        seen["hallway"] += 2 * h > 8.0
        sides = [side(r.origin[0], h) for r in s.robots]
        seen["inside"] += 0 in sides
        seen["one-sided"] += 0 not in sides and len(set(sides)) == 1
        seen["head-on"] += sides.count(-1) == sides.count(1) > 0
        seen["mouth"] += any(abs(abs(r.destination[0]) - h - r.radius) <= 0.3 and r.destination[1] == 0
                             for r in s.robots)
        seen["axis"] += any(r.destination[1] == 0 for r in s.robots)
        seen["mixed radii"] += len({r.radius for r in s.robots}) > 1
        seen["mixed speeds"] += len({r.max_speed for r in s.robots}) > 1
        seen["mixed accelerations"] += len({r.max_accel for r in s.robots}) > 1
        seen["slow"] += any(r.max_accel < 0.5 for r in s.robots)
        # A queue: some robot's start within the 5-80 cm spacing of another's, behind it.
        seen["queue"] += any(0 < math.dist(a.origin, b.origin) - a.radius - b.radius < 0.81
                             for a in s.robots for b in s.robots if a is not b)
    assert counts == {2, 3, 4}
    assert all(v > 0 for v in seen.values()), seen


def test_paper_like_keeps_the_papers_geometry(draws):
    for s in draws["paper-like"]:
        assert s.world.bounds == (-7.0, -2.5, 7.0, 2.5)
        assert (s.world.corridor.x_min, s.world.corridor.x_max, s.world.corridor.width) == (-3.0, 3.0, 0.7)
        assert {r.radius for r in s.robots} == {0.2}
        assert 2 <= s.n_robots <= 4


def test_crowded_has_five_to_eight_robots_and_two_players(draws):
    assert {s.n_robots for s in draws["crowded"]} == {5, 6, 7, 8}
    assert all(s.game_players == 2 for s in draws["crowded"])


# -- determinism ----------------------------------------------------------------------------------


def test_same_seed_same_scenario_and_different_seeds_differ():
    a = [draw(load_family("mixed"), s) for s in (1, 2, 3)]
    b = [draw(load_family("mixed"), s) for s in (1, 2, 3)]
    assert a == b
    assert len({scenario_to_dict(s)["robots"][0]["origin"][0] for s in a}) == 3


def test_draws_have_their_own_random_stream():
    first = draw_generator(7).random(4)
    decisions, sensing = trial_generators(7, 8)
    for g in decisions + sensing + [np.random.default_rng(7)]:
        assert not np.array_equal(first, g.random(4))


# -- specs, files and errors ----------------------------------------------------------------------


def test_family_seed_spec_loads_the_draw(tmp_path):
    assert load_scenario("paper-like:9") == draw(load_family("paper-like"), 9)
    path = tmp_path / "small.yaml"
    path.write_text("family: small\nrobots: {count: 2, radius: 0.2, mixed_radii: 0}\ninside: {probability: 0}\n")
    s = load_scenario(f"{path}:4")
    assert s.name == "small:4" and s.n_robots == 2 and str(path) in s.description
    assert parse_draw_spec("3r-case1") is None and parse_draw_spec("a:b:12") == ("a:b", 12)


def test_generate_writes_files_that_load_back_equal(tmp_path, capsys):
    assert main(["generate", "mixed", "--seed", "11", "--count", "3", "--out", str(tmp_path)]) == 0
    for s in (11, 12, 13):
        path = tmp_path / f"mixed-{s}.yaml"
        assert load_scenario(str(path)) == load_scenario(f"mixed:{s}")
        assert yaml.safe_load(path.read_text())["name"] == f"mixed:{s}"


def test_families_command_lists_the_builtins(capsys):
    assert main(["families"]) == 0
    out = capsys.readouterr().out
    assert builtin_families() == ["building", "building-one-door", "crowded", "meet-inside", "mixed", "paper-like"]
    assert all(name in out for name in builtin_families())


@pytest.mark.parametrize("text, message", [
    ("robots: {count: 3}\n", "family: expected a name"),
    ("family: x\ncoridor: {length: 3}\n", "unknown key 'coridor'; did you mean 'corridor'?"),
    ("family: x\ncorridor: {length: [5, 2]}\n", "corridor.length: low 5 is above high 2"),
    ("family: x\ncorridor: {length: long}\n", "corridor.length: expected a number (m), got 'long'"),
    ("family: x\nrobots: {count: [2, 12]}\n", "robots.count: expected a whole number or [low, high] in 2..8"),
    ("family: x\nrobots: {radius: 0.01}\n", "robots.radius: expected a number (m) in [0.08, 2]"),
    ("family: x\nrobots: {radius: 0.2}\ncorridor: {width: 0.9}\n", "corridor.width: [0.9, 0.9] m is not single file"),
    ("family: x\ncorridor: {width: 0.6, fit: 0.5}\n", "give either 'fit' or 'width'"),
    ("family: x\ntraffic: {head-on: 0}\n", "traffic: at least one weight must be positive"),
    ("family: x\nstarts: {formation: {queue: 1}}\n", "unknown key 'queue'"),
    ("family: x\nstarts: {gap: 0.0}\n", "starts.gap: expected a number (m) in [0.05, 30]"),
    ("family: x\ndestinations: {mouth: 2}\n", "destinations.mouth: expected a number (a probability) in [0, 1]"),
    ("family: x\nscenario: {opinion: {u: -1}}\n", "scenario.opinion.u: must be from 0 to 10000"),
    ("family: x\nscenario: {game_players: 3}\n", "scenario.game_players: expected 'all' or a whole number 0..1"),
    ("family: x\nscenario: {robots: []}\n", "scenario: unknown key 'robots'"),
    ("family: x\nrooms: {grow: maybe}\n", "rooms.grow: expected true or false"),
    ("family: [x\n", "invalid YAML"),
])
def test_family_file_errors_are_one_line(tmp_path, capsys, text, message):
    path = tmp_path / "fam.yaml"
    path.write_text(text)
    with pytest.raises(FamilyError, match=None) as info:
        load_family(str(path))
    assert message in str(info.value) and "\n" not in str(info.value)
    assert main(["generate", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nodnav: error: ") and message in err and "\n" not in err


def test_impossible_family_gives_up_with_a_clear_error():
    # Fixed 2 x 1.2 m rooms cannot hold four robots of radius 0.5 m.
    family = family_from_dict({"family": "tight", "robots": {"count": 4, "radius": 0.5, "mixed_radii": 0},
                               "rooms": {"depth": 2.0, "height": 1.2, "grow": False}}, "test")
    with pytest.raises(FamilyError, match=r"tight:1: no valid scenario in 200 attempts .*rooms.grow: true"):
        draw(family, 1)


def test_unknown_family_spec_is_one_line(capsys, tmp_path):
    assert main(["run", "mixd:3", "--seed", "3"]) == 2
    assert "mixd: no such built-in family or family file; did you mean 'mixed'?" in capsys.readouterr().err
    assert main(["show", "3r-case1", "--seed", "2", "--out", str(tmp_path / "x.png")]) == 2
    assert "--seed and --count draw from a family" in capsys.readouterr().err


def test_draws_do_not_depend_on_the_process():
    # Another interpreter, another hash seed: the same scenarios, to the last bit.
    import json
    import subprocess
    import sys

    code = ("import json; from nodnav.scenario.draws import draw; from nodnav.scenario.families import load_family; "
            "from nodnav.scenario.schema import scenario_to_dict; "
            "print(json.dumps([scenario_to_dict(draw(load_family('mixed'), s)) for s in (5, 6)]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONHASHSEED": "12345", "PATH": ""}).stdout
    here = [scenario_to_dict(draw(load_family("mixed"), s)) for s in (5, 6)]
    assert json.loads(out) == json.loads(json.dumps(here))


def test_plan_and_show_take_a_drawn_scenario(tmp_path, capsys):
    import json

    s = load_scenario("paper-like:3")
    order = ",".join(str(k) for k in range(1, s.n_robots + 1))
    main(["plan", "paper-like:3", "--order", order, "--json"])
    assert json.loads(capsys.readouterr().out)["planner"] == "fast"
    assert main(["show", "paper-like:3", "--out", str(tmp_path / "one.png")]) == 0
    assert (tmp_path / "one.png").stat().st_size > 0
