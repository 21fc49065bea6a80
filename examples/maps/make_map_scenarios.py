"""Write a scenario per public map in ../shared/maps: two robots crossing one door head-on.

For each map (and robot radius), the passages are found (:mod:`nodnav.scenario.passage_finding`)
and the first one at least 0.4 m long (those joining two regions first, then in the order
found) with room for a robot some way beyond each mouth is used: robot 1 starts 1.2 m (1.6,
2.0) before the first mouth and ends as far beyond the second, robot 2 the other way round,
each 0.3 m to its right of the axis (or on it). A candidate is kept only when the robots' shortest routes cross that passage and no other (the
loader checks it again). The scenarios name the maps by a path relative to this folder, i.e.
``../shared/maps`` from the repository's root; the maps are never copied here.

    .venv/bin/python examples/maps/make_map_scenarios.py [SHARED_MAPS_DIR]
"""

import sys
from pathlib import Path

import numpy as np

from nodnav.scenario.passage_finding import map_passages

HERE = Path(__file__).parent
MAPS = {"willow_2010": ("willow-2010-02-18-0.10.yaml", 0.2), "willow_full": ("willow-full-0.05.yaml", 0.2),
        "nav2_depot": ("depot.yaml", 0.4), "aws_small_house": ("map.yaml", 0.2)}


def crossing(path: Path, radius: float) -> tuple[list, int] | None:
    """Origins and destinations of two robots crossing one passage head-on, and its number."""
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
            used = map_passages(str(path), [radius, radius], robots).used_by
            if set(used) == {k} and len(used[k]) == 2:
                return [[[round(float(v), 2) for v in p] for p in pair] for pair in robots], k + 1
    return None


def main(shared: Path) -> None:
    for folder, (name, radius) in MAPS.items():
        path = shared / folder / name
        found = crossing(path, radius)
        if found is None:
            print(f"{folder}: no door found for two robots")
            continue
        robots, number = found
        rel = Path("..", "..", "..", "shared", "maps", folder, name)
        lines = [f"name: {folder}-door", f"description: Two robots of radius {radius:g} m cross passage {number} "
                 f"of the public map {folder} head-on (passage found on the map)", "world:", f"  map: {rel.as_posix()}",
                 f"robot_defaults: {{radius: {radius:g}}}", "robots:"]
        lines += [f"  - {{origin: {o}, destination: {d}}}" for o, d in robots]
        out = HERE / f"{folder}-door.yaml"
        out.write_text("\n".join(lines) + "\n")
        print(f"wrote {out} (passage {number})")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parents[1] / ".." / "shared" / "maps")
