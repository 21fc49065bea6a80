"""Occupancy-grid maps (issue 20, items 3 and 7): map_server's reading of pixels, exact walls and
bounds, the bounds on size, passages found on a hand-made corridor, and one line per bad map."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from nodnav.cli import main
from nodnav.scenario import maps
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.maps import free_cells, read_map, wall_boxes
from nodnav.scenario.passage_finding import find_passages
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict

RES = 0.1
ORIGIN = (-1.0, 0.5)
#: The hand-made map: 4 m x 2 m at 0.1 m, a wall from x = 1.5 to 2.5 m (map coordinates) pierced
#: by a corridor from y = 0.7 to 1.3 m: 0.6 m wide, single file for robots of radius 0.2 m.
COLS, ROWS = 40, 20
WALL_COLS, CORRIDOR_ROWS = slice(15, 25), slice(7, 13)


def corridor_walls() -> np.ndarray:
    """The wall cells, row 0 at the bottom."""
    wall = np.zeros((ROWS, COLS), dtype=bool)
    wall[:, WALL_COLS] = True
    wall[CORRIDOR_ROWS, WALL_COLS] = False
    return wall


def write_map(folder: Path, pixels: np.ndarray, name: str = "m", mode: str | None = None, **keys) -> Path:
    """A map YAML and its image (``pixels`` rows bottom first, as the grid)."""
    suffix = ".png" if pixels.ndim == 3 else ".pgm"
    Image.fromarray(pixels[::-1]).save(folder / f"{name}{suffix}")
    fields = {"image": f"{name}{suffix}", "resolution": RES, "origin": [*ORIGIN, 0.0], "negate": 0,
              "occupied_thresh": 0.65, "free_thresh": 0.196, **keys}
    if mode:
        fields["mode"] = mode
    text = "".join(f"{k}: {v}\n" for k, v in fields.items())
    (folder / f"{name}.yaml").write_text(text)
    return folder / f"{name}.yaml"


def corridor_map(folder: Path) -> Path:
    return write_map(folder, np.where(corridor_walls(), 0, 254).astype(np.uint8))


def scenario(map_path: str, robots=None, **world) -> dict:
    robots = robots or [{"origin": [-0.3, 1.3], "destination": [2.3, 1.7]},
                        {"origin": [2.3, 1.1], "destination": [-0.3, 1.1]}]
    return {"world": {"map": map_path, **world}, "robots": robots}


def test_walls_are_exactly_the_wall_cells_and_bounds_the_extent(tmp_path):
    m = read_map(corridor_map(tmp_path))
    assert m.bounds == pytest.approx((-1.0, 0.5, 3.0, 2.5))
    # The wall below and above the corridor, each one box (hand computation).
    assert np.allclose(sorted(m.walls), [(0.5, 0.5, 1.5, 1.2), (0.5, 1.8, 1.5, 2.5)])


@pytest.mark.parametrize("seed", range(5))
def test_wall_boxes_cover_exactly_the_wall_cells(seed):
    wall = np.random.default_rng(seed).random((37, 53)) < 0.4
    covered = np.zeros_like(wall)
    for j0, i0, j1, i1 in wall_boxes(wall):
        assert wall[i0:i1, j0:j1].all()  # a box holds wall cells only
        covered[i0:i1, j0:j1] = True
    assert (covered == wall).all()


def test_the_corridor_is_found_with_its_mouths_and_width(tmp_path):
    m = read_map(corridor_map(tmp_path))
    found = find_passages(m, one=0.2, abreast=0.4)
    assert len(found) == 1
    g = found[0].passage
    # Independent reference: on the centreline y = 1.5 (world), outside the wall the clearance is
    # the distance to the wall's corner, hypot(d, 0.3); two robots of 0.2 m pass abreast where it
    # reaches 0.4, d = sqrt(0.4^2 - 0.3^2) = 0.265 m beyond each face (x = 0.5 and 1.5).
    d = math.sqrt(0.4**2 - 0.3**2)
    mouths = sorted([g.start, g.end])
    assert mouths[0][0] == pytest.approx(0.5 - d, abs=RES) and mouths[1][0] == pytest.approx(1.5 + d, abs=RES)
    assert all(abs(y - 1.5) <= RES for _, y in mouths)
    assert 0.6 - RES <= g.width <= 0.6


def test_a_scenario_on_the_map_finds_its_passage_and_round_trips(tmp_path):
    path = corridor_map(tmp_path)
    s = scenario_from_dict(scenario(str(path)))
    w = s.world
    assert w.bounds == pytest.approx((-1.0, 0.5, 3.0, 2.5)) and w.map_file == str(path.resolve())
    assert w.map_walls == 2 and len(w.obstacles) == 2
    assert abs(w.passage.axis[0]) == pytest.approx(1.0, abs=0.05)
    again = scenario_from_dict(scenario_to_dict(s))
    assert again.world.passages == w.passages and again.world.obstacles == w.obstacles


def test_the_map_path_is_relative_to_the_scenario_file(tmp_path, monkeypatch):
    corridor_map(tmp_path)
    (tmp_path / "s.yaml").write_text(
        "world: {map: m.yaml}\nrobots:\n  - {origin: [-0.3, 1.3], destination: [2.3, 1.7]}\n"
        "  - {origin: [2.3, 1.1], destination: [-0.3, 1.1]}\n")
    monkeypatch.chdir("/")
    assert load_scenario(tmp_path / "s.yaml").world.map_walls == 2


# -- map_server's reading of pixels ------------------------------------------------------------


def test_trinary_thresholds_and_negate():
    shade = np.array([254, 0, 205, 100, 160]) / 255.0
    # p = 1 - shade: 0.004 free; 1.0 occupied; 0.196 is not below free_thresh (unknown, map_saver's 205).
    assert free_cells(shade, None, False, 0.65, 0.196, "trinary").tolist() == [True, False, False, False, False]
    # negate: p = shade.
    assert free_cells(shade, None, True, 0.65, 0.196, "trinary").tolist() == [False, True, False, False, False]
    assert free_cells(np.array([160 / 255]), None, False, 0.65, 0.4, "trinary").tolist() == [True]


def test_scale_mode_makes_transparent_pixels_unknown_and_raw_mode_reads_percent():
    shade, alpha = np.array([1.0, 1.0]), np.array([1.0, 0.5])
    assert free_cells(shade, alpha, False, 0.65, 0.196, "scale").tolist() == [True, False]
    assert free_cells(shade, alpha, False, 0.65, 0.196, "trinary").tolist() == [True, True]
    raw = np.array([0, 19, 20, 100, 255]) / 255.0  # occupancy percent; 255 unknown
    assert free_cells(raw, None, False, 0.65, 0.196, "raw").tolist() == [True, True, False, False, False]


def test_colour_png_reads_the_mean_of_its_channels(tmp_path):
    rgb = np.zeros((ROWS, COLS, 3), dtype=np.uint8)
    rgb[~corridor_walls()] = (254, 254, 254)
    rgb[corridor_walls()] = (255, 0, 0)  # mean 85: occupancy 0.67, a wall
    m = read_map(write_map(tmp_path, rgb, name="rgb"))
    assert np.allclose(sorted(m.walls), [(0.5, 0.5, 1.5, 1.2), (0.5, 1.8, 1.5, 2.5)])


# -- bounds and bad maps ------------------------------------------------------------------------


def test_a_map_larger_than_the_bound_is_refused_before_decoding(tmp_path, monkeypatch):
    path = corridor_map(tmp_path)
    monkeypatch.setattr(maps, "MAX_MAP_CELLS", 799)
    maps._read_map_cached.cache_clear()
    with pytest.raises(ScenarioError, match="40 x 20 = 800 cells, more than 799"):
        read_map(path)
    maps._read_map_cached.cache_clear()


def test_a_map_needing_too_many_wall_boxes_is_refused(tmp_path, monkeypatch):
    path = corridor_map(tmp_path)
    monkeypatch.setattr(maps, "MAX_MAP_WALLS", 1)
    maps._read_map_cached.cache_clear()
    with pytest.raises(ScenarioError, match="needs 2 wall boxes, more than 1"):
        read_map(path)
    maps._read_map_cached.cache_clear()


def _bad(tmp_path: Path, case: str) -> dict:
    path = corridor_map(tmp_path)
    text = path.read_text()
    if case == "missing image":
        path.write_text(text.replace("m.pgm", "nothing.pgm"))
    elif case == "unreadable image":
        (tmp_path / "m.pgm").write_bytes(b"not an image")
    elif case == "resolution 0":
        path.write_text(text.replace("resolution: 0.1", "resolution: 0"))
    elif case == "negative resolution":
        path.write_text(text.replace("resolution: 0.1", "resolution: -0.05"))
    elif case == "no free space":
        write_map(tmp_path, np.zeros((ROWS, COLS), dtype=np.uint8))
    elif case == "robot in a wall":
        return scenario(str(path), [{"origin": [1.0, 0.8], "destination": [2.3, 1.7]},
                                    {"origin": [2.3, 1.1], "destination": [-0.3, 1.1]}])
    elif case == "not single file":
        return scenario(str(path), [{"origin": [-0.3, 1.3], "destination": [2.3, 1.7], "radius": 0.1},
                                    {"origin": [2.3, 1.1], "destination": [-0.3, 1.1], "radius": 0.1}],
                        passages=[{"from": [0.5, 1.5], "to": [1.5, 1.5], "width": 0.6}])
    elif case == "overlapping passages":
        return scenario(str(path), passages=[{"from": [0.5, 1.5], "to": [1.5, 1.5], "width": 0.6},
                                             {"from": [0.6, 1.5], "to": [1.4, 1.5], "width": 0.6}])
    elif case == "no passage on the routes":
        return scenario(str(path), [{"origin": [-0.5, 1.0], "destination": [0.0, 2.0]},
                                    {"origin": [0.0, 1.0], "destination": [-0.5, 2.0]}])
    elif case == "turned map":
        path.write_text(text.replace("0.0]", "0.5]"))
    maps._read_map_cached.cache_clear()
    return scenario(str(path))


@pytest.mark.parametrize("case, key, words", [
    ("missing image", "world.map", "does not exist"),
    ("unreadable image", "world.map", "cannot read the map's image"),
    ("resolution 0", "world.map", "must be above 0"),
    ("negative resolution", "world.map", "must be above 0"),
    ("no free space", "world.map", "has no free cell"),
    ("robot in a wall", "robots[0].origin", "within 0.2 m of a wall of the map"),
    ("not single file", "world.passages[0]", "is not single file"),
    ("overlapping passages", "world.passages[1]", "overlaps world.passages[0]"),
    ("no passage on the routes", "world.map", "cross none of the map's 1 single-file passages"),
    ("turned map", "world.map", "turned map"),
])
def test_bad_maps_get_one_line(tmp_path, case, key, words):
    raw = _bad(tmp_path, case)
    with pytest.raises(ScenarioError) as exc:
        scenario_from_dict(raw)
    message = str(exc.value)
    assert message.startswith(key) and words in message and "\n" not in message


def test_bad_map_from_the_command_line_exits_2(tmp_path, capsys):
    path = corridor_map(tmp_path)
    path.write_text(path.read_text().replace("resolution: 0.1", "resolution: 0"))
    maps._read_map_cached.cache_clear()
    assert main(["passages", str(path), "--radius", "0.2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nodnav: error: ") and "must be above 0" in err and "\n" not in err


def test_passages_command_lists_the_corridor(tmp_path, capsys):
    path = corridor_map(tmp_path)
    assert main(["passages", str(path), "--radius", "0.2", "--out", str(tmp_path / "m.png")]) == 0
    out = capsys.readouterr().out
    width = float(out.split("width ")[1].split(" m")[0])
    assert ": 1 passages" in out and 0.6 - RES <= width <= 0.6 and (tmp_path / "m.png").is_file()


def test_bounds_crop_the_map_to_the_cells_they_meet(tmp_path):
    m = read_map(corridor_map(tmp_path)).cropped((-1.0, 0.5, 1.04, 2.5))
    # The crop ends at the first cell boundary at or beyond x = 1.04, x = 1.1, inside the wall: its
    # two boxes end there (hand computation).
    assert np.allclose(sorted(m.walls), [(0.5, 0.5, 1.1, 1.2), (0.5, 1.8, 1.1, 2.5)])
    assert m.bounds == pytest.approx((-1.0, 0.5, 1.1, 2.5))


def two_doors_map(folder: Path) -> Path:
    """Three rooms in a row, 6 m x 2 m, joined by two 0.6 m corridors through 1 m thick walls."""
    wall = np.zeros((ROWS, 60), dtype=bool)
    for cols in (slice(15, 25), slice(35, 45)):
        wall[:, cols] = True
        wall[CORRIDOR_ROWS, cols] = False
    return write_map(folder, np.where(wall, 0, 254).astype(np.uint8), name="two")


def test_routes_through_two_found_passages_keep_both(tmp_path):
    raw = scenario(str(two_doors_map(tmp_path)), [{"origin": [-0.3, 1.3], "destination": [4.3, 1.7]},
                                                   {"origin": [4.3, 1.1], "destination": [-0.3, 1.1]}])
    passages = scenario_from_dict(raw).world.passages
    # the corridors through the walls of cells 15-24 and 35-44 (origin x = -1: x 0.5..1.5 and 2.5..3.5)
    assert len(passages) == 2
    centres = sorted(0.5 * (g.start[0] + g.end[0]) for g in passages)
    assert centres == pytest.approx([1.0, 3.0], abs=RES)


def test_robots_using_one_of_two_passages_get_it(tmp_path):
    raw = scenario(str(two_doors_map(tmp_path)), [{"origin": [2.0, 1.3], "destination": [4.3, 1.7]},
                                                   {"origin": [4.3, 1.1], "destination": [2.0, 1.1]}])
    g = scenario_from_dict(raw).world.passage
    # The second corridor: map x from 3.5 to 4.5 m (hand computation), so its middle is at x = 3.0.
    assert 0.5 * (g.start[0] + g.end[0]) == pytest.approx(3.0, abs=RES)


def test_passages_command_on_a_scenario_names_the_robots_using_each(tmp_path, capsys):
    two_doors_map(tmp_path)
    (tmp_path / "s.yaml").write_text(
        "world: {map: two.yaml}\nrobots:\n  - {origin: [2.0, 1.3], destination: [4.3, 1.7]}\n"
        "  - {origin: [4.3, 1.1], destination: [2.0, 1.1]}\n")
    assert main(["passages", str(tmp_path / "s.yaml")]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert ": 2 passages" in lines[0] and "used by" not in lines[1] and lines[2].endswith("used by robots 1, 2")


def test_show_draws_a_map_yaml(tmp_path, capsys):
    path = corridor_map(tmp_path)
    assert main(["show", str(path), "--out", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m.png").is_file() and "radius 0.2 m" in capsys.readouterr().out
