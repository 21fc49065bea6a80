"""Maps in use: the floor plan nodnav writes (examples/maps), a trial on it, and the public maps
of ../shared/maps (skipped where that folder is absent)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest

from nodnav.scenario.loading import load_scenario
from nodnav.scenario.maps import read_map, write_map
from nodnav.scenario.passage_finding import map_passages

ROOT = Path(__file__).parents[2]
EXAMPLES = ROOT / "examples" / "maps"
#: The public maps, ../shared/maps from the repository's root (NODNAV_SHARED_MAPS overrides it).
SHARED = Path(os.environ.get("NODNAV_SHARED_MAPS", ROOT / ".." / "shared" / "maps"))
PUBLIC = {"willow_2010": "willow-2010-02-18-0.10.yaml", "willow_full": "willow-full-0.05.yaml",
          "nav2_depot": "depot.yaml", "aws_small_house": "map.yaml"}


def floor_plan():
    import importlib.util

    spec = importlib.util.spec_from_file_location("write_floor_plan", EXAMPLES / "write_floor_plan.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.floor_plan()


def test_write_map_reads_back_as_the_same_walls(tmp_path):
    world = floor_plan()
    m = read_map(write_map(world, tmp_path / "plan.yaml", 0.05))
    assert m.bounds == pytest.approx(world.bounds)
    # Every wall of the plan is on the 0.05 m grid, so the cells' centres decide exactly: a point
    # is free on the map exactly when it is free in the world (checked at random points).
    p = np.random.default_rng(0).uniform(world.bounds[:2], world.bounds[2:], (2000, 2))
    i, j = m.cell_of(p)
    cell_free = world.clearance(m.centre_of(i, j)) > 0
    assert (m.free[i, j] == cell_free).all()


def test_the_shipped_floor_plan_is_what_the_script_writes(tmp_path):
    written = write_map(floor_plan(), tmp_path / "floor_plan.yaml", 0.05)
    assert (tmp_path / "floor_plan.pgm").read_bytes() == (EXAMPLES / "floor_plan.pgm").read_bytes()
    assert written.read_text() == (EXAMPLES / "floor_plan.yaml").read_text()


def test_a_short_trial_on_the_floor_plan():
    from nodnav.sim.simulator import run_trial

    s = load_scenario(EXAMPLES / "floor_plan_crossing.yaml")
    assert s.world.map_walls > 0 and s.world.passage.width == pytest.approx(0.7, abs=0.05)
    result = run_trial(s.with_overrides(time_limit=4.0), seed=1)
    assert result.collisions == 0 and result.outcome in ("success", "timeout")


@pytest.mark.skipif(not SHARED.is_dir(), reason="../shared/maps is absent")
@pytest.mark.parametrize("folder", sorted(PUBLIC))
def test_public_maps_load_in_bounded_time_and_have_passages(folder):
    start = time.perf_counter()
    result = map_passages(str(SHARED / folder / PUBLIC[folder]), [0.2, 0.2])
    assert time.perf_counter() - start < 30.0
    m = result.map
    assert 0 < len(m.walls) <= 20_000 and m.free.any()
    assert len(result.found) >= 1
    for f in result.found:
        assert 0.4 <= f.width < 0.8 + 1e-9  # single file for r = 0.2: one fits, two do not
