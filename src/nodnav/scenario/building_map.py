"""A drawn floor plan written as a ROS map_server map (PGM + YAML) and a scenario file that uses it.

``nodnav generate building --seed N --map OUT.yaml`` draws the plan
(:func:`nodnav.scenario.draws.draw_building`), rasterises its walls and furniture with
:func:`nodnav.scenario.maps.write_map` (free 254, walls 0; a cell is a wall when its centre is in
a wall), and writes a scenario whose ``world.map`` is that map (relative to the scenario file) and
whose ``world.passages`` are the plan's passages, so that nothing depends on finding them again.

The map's extent is the plan's bounds grown to a whole number of cells (the strip added is wall).
Rasterising moves a wall's face by up to half a cell diagonal, so a passage's clear width on the
map is within ``sqrt(2) resolution`` of the plan's; the default resolution, :data:`RESOLUTION`,
keeps every drawn width single file on the map (the widths stay 0.05 m below two robots abreast
and 0.1 m above the largest robot). The written map is read back and each passage checked; a
resolution too coarse for a passage is one line.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from nodnav.scenario.building_check import Plan
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.world import World

RESOLUTION = 0.02
"""Default cell size (m) of a written floor plan: ``sqrt(2) 0.02 = 0.028`` m below the margins of
the drawn widths (0.05 m to two abreast, 0.1 m over the largest robot)."""


def _grown(bounds, resolution: float) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = bounds
    cols, rows = math.ceil((x1 - x0) / resolution - 1e-9), math.ceil((y1 - y0) / resolution - 1e-9)
    return x0, y0, x0 + cols * resolution, y0 + rows * resolution


def plan_world(mapping: dict, resolution: float) -> World:
    """The plan's walls as a world whose bounds are a whole number of cells (the strip added is wall)."""
    plan = Plan(mapping)
    x0, y0, x1, y1 = plan.bounds
    gx0, gy0, gx1, gy1 = _grown(plan.bounds, resolution)
    strips = tuple(b for b in ((x1, gy0, gx1, gy1), (gx0, y1, gx1, gy1)) if b[0] < b[2] and b[1] < b[3])
    return World(bounds=(gx0, gy0, gx1, gy1), obstacles=tuple(plan.world.obstacles) + strips,
                 passages=plan.world.passages, polygons=plan.world.polygons)


def write_building(mapping: dict, map_path: str | Path, scenario_dir: str | Path | None = None,
                   resolution: float = RESOLUTION) -> tuple[Path, Path]:
    """Write the plan of ``mapping`` as ``map_path`` (YAML) and its PGM, and the scenario using it
    (``NAME-SEED.yaml`` in ``scenario_dir``, default the map's folder). Returns both paths."""
    from nodnav.scenario.maps import _read_map_cached, read_map, write_map

    if not (isinstance(resolution, (int, float)) and 0.005 <= resolution <= 0.2):
        raise ScenarioError(f"--resolution: expected metres per cell in [0.005, 0.2], got {resolution!r}")
    map_path = Path(map_path)
    if map_path.suffix.lower() not in (".yaml", ".yml"):
        raise ScenarioError(f"--map: the map's file is a map_server YAML; give a name ending in .yaml, got "
                            f"{str(map_path)!r}")
    out = Path(scenario_dir) if scenario_dir is not None else map_path.parent
    try:
        map_path.parent.mkdir(parents=True, exist_ok=True)
        out.mkdir(parents=True, exist_ok=True)
        write_map(plan_world(mapping, resolution), map_path, resolution)
    except OSError as exc:
        raise ScenarioError(f"--map: cannot write {map_path} ({exc.strerror or exc})") from None
    _read_map_cached.cache_clear()  # the file at this path may have been read before it was written
    m = read_map(map_path)
    _check_widths(mapping, m, resolution)
    scenario = {k: v for k, v in mapping.items() if k not in ("world", "name", "description")}
    name = str(mapping["name"]).replace(":", "-")
    rel = Path(_relative(map_path.resolve(), out.resolve()))
    scenario = {
        "name": f"{name}-map",
        "description": f"{mapping['description']}; its floor plan as the map {map_path.name} "
                       f"({resolution:g} m cells, written by nodnav generate --map)",
        **scenario,
        "world": {"map": str(rel), "passages": mapping["world"]["passages"]},
    }
    path = out / f"{name}.yaml"
    try:
        path.write_text(yaml.safe_dump(scenario, sort_keys=False))
    except OSError as exc:
        raise ScenarioError(f"--out: cannot write {path} ({exc.strerror or exc})") from None
    return map_path, path


def _relative(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(target, start)


def _check_widths(mapping: dict, m, resolution: float) -> None:
    """Each passage's clear width on the written map is single file for the robots (one line if not)."""
    from nodnav.scenario.world_schema import check_single_file

    plan = Plan(mapping)
    for k, g in enumerate(plan.passages):
        world = World(bounds=m.bounds, obstacles=m.walls, passages=(g,), map_walls=len(m.walls))
        a, b = np.asarray(g.start), np.asarray(g.end)
        gap = 2.0 * float(world.clearance(a + np.linspace(0.0, 1.0, 50)[:, None] * (b - a)).min())
        try:
            check_single_file(world, plan.radii, f"world.passages[{k}]")
        except ScenarioError:
            gap_text = f"{gap:.3f}"
            raise ScenarioError(f"--resolution: at {resolution:g} m per cell passage {k + 1} leaves {gap_text} m on "
                                f"the map, not single file for these robots; give a finer --resolution") from None
        if gap < 2 * float(plan.radii.max()) + 0.02:
            raise ScenarioError(f"--resolution: at {resolution:g} m per cell passage {k + 1} leaves {gap:.3f} m on "
                                f"the map, too narrow for the largest robot; give a finer --resolution")
