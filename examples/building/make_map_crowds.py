"""Write a scenario per public map in ../shared/maps: four robots (else three) queueing at both mouths of one door.

The two-robot head-on scenarios of examples/maps (make_map_scenarios.py) are the easy case; these
put a queue of two at each mouth of one found passage. For each map and robot radius r, the
found passages at least 0.4 m long and straight are tried (those joining two regions first, then
in the order found). In the passage's frame (s along the axis, t across it), with a lateral
offset L (r + 0.15 m, else r + 0.08 m) and queue places b1 (1 + 2r, 1.5 + 2r, 0.8 + 2r or
2.2 + 2r m) and b2 = b1 + 2r + 0.2 m beyond a mouth, the first that fits:

* robots 1 and 2 start b1 and b2 before the first mouth at t = +L and end as far beyond the
  second, at t = +L;
* robots 3 and 4 start b1 and b2 beyond the second mouth at t = -L and end as far before the
  first, at t = -L.

Where no passage gives four, robot 4 is left out and three are tried. A candidate is kept when
every end has at least r + 0.1 m of clearance on the map and, on the scenario's window (a box
3 m round the robots' ends, the scenario's bounds), every robot's shortest route crosses that
passage and no other, and the scenario loads. Radii: 0.2 m on the Willow Garage maps; in the
house 0.3 m (as in examples/maps), else 0.25 or 0.2 m; in the depot 0.4 m (as in
examples/maps), else 0.35 or 0.3 m: the first radius that gives a scenario.

    .venv/bin/python examples/building/make_map_crowds.py [SHARED_MAPS_DIR]
"""

import sys
from pathlib import Path

import numpy as np

from nodnav.scenario.passage_finding import clearance_grid, map_passages

HERE = Path(__file__).parent
MAPS = {"willow_2010": ("willow-2010-02-18-0.10.yaml", (0.2,)), "willow_full": ("willow-full-0.05.yaml", (0.2,)),
        "nav2_depot": ("depot.yaml", (0.4, 0.35, 0.3)), "aws_small_house": ("map.yaml", (0.3, 0.25, 0.2))}


def window(m, ends: np.ndarray) -> list[float]:
    """A box 3 m round the robots' ends, on the map's cell boundaries, inside its extent."""
    r, (x0, y0) = m.resolution, m.origin
    lo = np.floor((ends.min(axis=0) - 3.0 - (x0, y0)) / r) * r + (x0, y0)
    hi = np.ceil((ends.max(axis=0) + 3.0 - (x0, y0)) / r) * r + (x0, y0)
    b = m.bounds
    return [round(float(v), 3) for v in (max(lo[0], b[0]), max(lo[1], b[1]), min(hi[0], b[2]), min(hi[1], b[3]))]


def queues(path: Path, radius: float):
    """Four robots' (origin, destination), the passage's middle and the window, or None."""
    base = map_passages(str(path), [radius, radius])
    c = clearance_grid(base.map)
    candidates = [k for k, f in enumerate(base.found) if f.passage.length >= 0.4 and f.straight]
    candidates.sort(key=lambda k: not base.found[k].joins_regions)
    for k in candidates:
        g = base.found[k].passage
        axis, normal = np.array(g.axis), np.array(g.normal)
        start, end = np.array(g.start), np.array(g.end)
        for count in (4, 3):
            for lateral in (radius + 0.15, radius + 0.08):
                for b1 in (1.0 + 2 * radius, 1.5 + 2 * radius, 0.8 + 2 * radius, 2.2 + 2 * radius):
                    b2 = b1 + 2 * radius + 0.2
                    robots = [(start - b * axis + lateral * normal, end + b * axis + lateral * normal)
                              for b in (b1, b2)]
                    robots += [(end + b * axis - lateral * normal, start - b * axis - lateral * normal)
                               for b in (b1, b2)]
                    robots = robots[:count]
                    ends = np.array([p for pair in robots for p in pair])
                    i, j = base.map.cell_of(ends)
                    if (c[i, j] < radius + 0.1).any():
                        continue
                    bounds = window(base.map, ends)
                    crop = map_passages(str(path), [radius] * count, robots, bounds=tuple(bounds))
                    if len(crop.used_by) == 1 and sorted(next(iter(crop.used_by.values()))) == list(range(count)):
                        g = crop.found[next(iter(crop.used_by))].passage
                        mid = [round(0.5 * (g.start[i] + g.end[i]), 2) for i in range(2)]
                        return [[[round(float(v), 2) for v in p] for p in pair] for pair in robots], mid, bounds
    return None


def main(shared: Path) -> None:
    from nodnav.scenario.loading import load_scenario

    for folder, (name, radii) in MAPS.items():
        for radius in radii:
            found = queues(shared / folder / name, radius)
            if found is not None:
                break
        if found is None:
            print(f"{folder}: no door with room for two queues of two")
            continue
        robots, mid, bounds = found
        rel = Path("..", "..", "..", "shared", "maps", folder, name)
        what = (f"{len(robots)} robots of radius {radius:g} m queueing at both mouths cross the door at {mid} "
                f"of the public map {folder} head-on (passage found on the map)")
        lines = [f"name: {folder}-queues", f"description: {what}", "world:",
                 f"  map: {rel.as_posix()}", f"  bounds: {bounds}  # the map cropped round the door",
                 f"robot_defaults: {{radius: {radius:g}}}", "robots:"]
        lines += [f"  - {{origin: {o}, destination: {d}}}" for o, d in robots]
        out = HERE / f"{folder}-queues.yaml"
        out.write_text("\n".join(lines) + "\n")
        absolute = out.with_name(out.stem + ".check.yaml")
        absolute.write_text(out.read_text().replace(rel.as_posix(), str((shared / folder / name).resolve())))
        try:
            load_scenario(str(absolute))  # it loads: one passage on the routes, robots clear of walls
        finally:
            absolute.unlink()
        print(f"wrote {out} (the door at {mid})")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parents[1] / ".." / "shared" / "maps")
