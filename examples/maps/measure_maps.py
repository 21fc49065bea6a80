"""Measure a map: load time, wall boxes, peak memory, passages found, clearance query cost
(looping over every wall, and through the world's wall index), and the PRM* planner's compiled
joint check of a straight two-robot edge (the same two ways, with the verdicts compared).

    .venv/bin/python examples/maps/measure_maps.py MAP.yaml RADIUS [RADIUS ...]

Run once per map in a fresh process (peak memory is the process's, imports included); the
imports and the compiled kernel are loaded before the clock starts.
"""

import resource
import sys
import time
from pathlib import Path

import numpy as np

from nodnav.geometry import _segment_clearance_kernel, clearance_of, segment_clearance
from nodnav.scenario.maps import read_map, wall_boxes
from nodnav.scenario.passage_finding import clearance_grid, find_passages, medial_axis
from nodnav.scenario.world import Passage, World


def main(path: str, radii: list[float]) -> None:
    wall_boxes(np.zeros((2, 2), dtype=bool))  # load the compiled kernel before timing
    import skimage.morphology  # noqa: F401  (imports are not the map's cost)

    t0 = time.perf_counter()
    m = read_map(path)
    t1 = time.perf_counter()
    c = clearance_grid(m)
    axis = medial_axis(m)
    t2 = time.perf_counter()
    rows, cols = m.shape
    found = {r: find_passages(m, r, 2 * r, c, axis) for r in radii}
    t3 = time.perf_counter()
    # Cost of the clearance of one point among all the map's walls (the kernels loop over them).
    x0, y0, x1, y1 = m.bounds
    world = World(bounds=m.bounds, obstacles=m.walls, map_walls=len(m.walls),
                  passages=(Passage(start=(x0 + 1, y0 + 1), end=(x0 + 2, y0 + 1), width=0.5),))
    rng = np.random.default_rng(0)
    pts = rng.uniform((x0, y0), (x1, y1), (1000, 2))
    ends = pts + rng.normal(0.0, 0.5, pts.shape)  # segments of about half a metre
    world.clearance(pts[:1])
    segment_clearance(world, pts[:1], ends[:1])
    loop = min(_timed(lambda: clearance_of(pts, world.bounds_array, world.obstacle_array)) for _ in range(5))
    indexed = min(_timed(lambda: world.clearance(pts)) for _ in range(5))
    seg_loop = min(_timed(lambda: _segment_clearance_kernel(pts, ends, world.obstacle_array, world.bounds_array,
                                                            world.piece_array)) for _ in range(5))
    seg_indexed = min(_timed(lambda: segment_clearance(world, pts, ends)) for _ in range(5))
    # The PRM* planner's joint check of straight edges of two robots of radius 0.2 m both in free
    # space, through the index and looping over every wall (the same world without the index).
    import dataclasses

    from nodnav.planning.joint_validity import CompiledRules

    pairs = rng.uniform((x0, y0, x0, y0), (x1, y1, x1, y1), (200000, 4))
    pairs = pairs[np.all(world.clearance(pairs.reshape(-1, 2, 2)) >= 0.2, axis=1)][:2000]
    pair_ends = pairs + rng.normal(0.0, 0.5, pairs.shape)
    rules = [CompiledRules.of(w, np.full(2, 0.2), np.array([1, -1]), np.array([0.45]))
             for w in (world, dataclasses.replace(world, map_walls=0))]
    for r in rules:
        r.motions_ok(pairs[:2], pair_ends[:2])
    edge = [min(_timed(lambda rule=r: rule.motions_ok(pairs, pair_ends), len(pairs)) for _ in range(5)) for r in rules]
    agree = np.array_equal(rules[0].motions_ok(pairs, pair_ends), rules[1].motions_ok(pairs, pair_ends))
    best = f"{loop * 1e6:.1f} us looping over every wall, {indexed * 1e6:.2f} us indexed"
    seg = f"{seg_loop * 1e6:.1f} us / {seg_indexed * 1e6:.2f} us"
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    per_r = "; ".join(f"r = {r:g} m: {len(f)} passages ({sum(p.joins_regions for p in f)} joining two regions, "
                      f"{sum(p.straight for p in f)} straight)" for r, f in found.items())
    print(f"{Path(path).parent.name}: {cols} x {rows} cells of {m.resolution:g} m, {m.free.mean():.0%} free; "
          f"{len(m.walls)} wall boxes; load {t1 - t0:.2f} s, clearance and medial axis {t2 - t1:.2f} s, "
          f"finding {t3 - t2:.2f} s; peak memory {peak:.0f} MB; clearance of one point {best}; of a 0.5 m segment "
          f"{seg}; PRM* joint check of a two-robot edge {edge[1] * 1e6:.1f} us / {edge[0] * 1e6:.2f} us "
          f"(same verdicts: {agree}); {per_r}")


def _timed(call, queries: int = 1000) -> float:
    """Seconds per query of one call over ``queries`` queries."""
    start = time.perf_counter()
    call()
    return (time.perf_counter() - start) / queries


if __name__ == "__main__":
    main(sys.argv[1], [float(r) for r in sys.argv[2:]])
