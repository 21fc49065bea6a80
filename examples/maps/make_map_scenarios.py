"""Write a scenario per public map in ../shared/maps: two robots crossing one door head-on.

For each map (and robot radius), the passages are found (:mod:`nodnav.scenario.passage_finding`)
and the first one at least 0.4 m long (those joining two regions first, then in the order
found) with room for a robot some way beyond each mouth is used: robot 1 starts 1.2 m (1.6,
2.0) before the first mouth and ends as far beyond the second, robot 2 the other way round,
each 0.3 m to its right of the axis (or on it). A candidate is kept only when, on the
scenario's window of the map (a box 3 m round the robots' ends, which the scenario's bounds crop
the map to: fewer walls, and every clearance query loops over them), the robots' shortest routes
cross one passage and no other (the loader checks it again). The house's doorways are wider
than two robots of 0.2 m abreast, so its robots have radius 0.3 m (the depot's 0.4 m). The
scenarios name the maps by a path relative to this folder, i.e. ``../shared/maps`` from the
repository's root; the maps are never copied here.

    .venv/bin/python examples/maps/make_map_scenarios.py [SHARED_MAPS_DIR]
"""

import sys
from pathlib import Path

import numpy as np

from nodnav.scenario.passage_finding import map_passages

HERE = Path(__file__).parent
MAPS = {"willow_2010": ("willow-2010-02-18-0.10.yaml", 0.2), "willow_full": ("willow-full-0.05.yaml", 0.2),
        "nav2_depot": ("depot.yaml", 0.4), "aws_small_house": ("map.yaml", 0.3)}


def window(m, ends: np.ndarray) -> list[float]:
    """A box 3 m round the robots' ends, on the map's cell boundaries, inside its extent."""
    r, (x0, y0) = m.resolution, m.origin
    lo = np.floor((ends.min(axis=0) - 3.0 - (x0, y0)) / r) * r + (x0, y0)
    hi = np.ceil((ends.max(axis=0) + 3.0 - (x0, y0)) / r) * r + (x0, y0)
    b = m.bounds
    return [round(float(v), 3) for v in (max(lo[0], b[0]), max(lo[1], b[1]), min(hi[0], b[2]), min(hi[1], b[3]))]


def crossing(path: Path, radius: float) -> tuple[list, list, list] | None:
    """Origins and destinations of two robots crossing one passage head-on, its middle, and the
    window of the map the scenario keeps."""
    from nodnav.scenario.passage_finding import clearance_grid

    base = map_passages(str(path), [radius, radius])
    c = clearance_grid(base.map)
    candidates = [k for k, f in enumerate(base.found) if f.passage.length >= 0.4 and f.straight]
    candidates.sort(key=lambda k: not base.found[k].joins_regions)  # doors between regions first
    for k in candidates:
        g = base.found[k].passage
        axis, normal = np.array(g.axis), np.array(g.normal)
        for beyond, aside in ((1.2, 0.3), (1.6, 0.3), (2.0, 0.3), (1.2, 0.0), (2.0, 0.0)):
            a = np.array(g.start) - beyond * axis
            b = np.array(g.end) + beyond * axis
            robots = [(a - aside * normal, b - aside * normal), (b + aside * normal, a + aside * normal)]
            ends = np.array([p for pair in robots for p in pair])
            i, j = base.map.cell_of(ends)
            if (c[i, j] < radius + 0.1).any():
                continue
            bounds = window(base.map, ends)
            crop = map_passages(str(path), [radius, radius], robots, bounds=tuple(bounds))
            if len(crop.used_by) == 1 and sorted(next(iter(crop.used_by.values()))) == [0, 1]:
                g = crop.found[next(iter(crop.used_by))].passage
                mid = [round(0.5 * (g.start[i] + g.end[i]), 2) for i in range(2)]
                return [[[round(float(v), 2) for v in p] for p in pair] for pair in robots], mid, bounds
    return None


def main(shared: Path) -> None:
    for folder, (name, radius) in MAPS.items():
        path = shared / folder / name
        found = crossing(path, radius)
        if found is None:
            print(f"{folder}: no door found for two robots")
            continue
        robots, mid, bounds = found
        rel = Path("..", "..", "..", "shared", "maps", folder, name)
        lines = [f"name: {folder}-door", f"description: Two robots of radius {radius:g} m cross the door at {mid} "
                 f"of the public map {folder} head-on (passage found on the map)", "world:", f"  map: {rel.as_posix()}",
                 f"  bounds: {bounds}  # the map cropped round the door",
                 f"robot_defaults: {{radius: {radius:g}}}", "robots:"]
        lines += [f"  - {{origin: {o}, destination: {d}}}" for o, d in robots]
        out = HERE / f"{folder}-door.yaml"
        out.write_text("\n".join(lines) + "\n")
        print(f"wrote {out} (the door at {mid})")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parents[1] / ".." / "shared" / "maps")
