"""Random worlds of rooms in series joined by single-file corridors, turned by a random angle,
with robots whose routes cross one to three corridors; run each once (docs/several-passages.md).

    .venv/bin/python tools/several_passages_draws.py --draws 40 [--method nod] [--first 1]

Draw ``d`` uses ``numpy.random.default_rng(d)`` and runs with seed ``d``. Layout: 3 or 4 rooms
3-5 m wide and 4-6 m high in a row, corridors 1.5-3 m long and 0.6-0.75 m wide at a random
height through walls between them; 3-6 robots of radius 0.2 m, each from one room to another
(never its own), origins and destinations at least 0.5 m from the walls and 0.6 m from each
other's; the whole world turned by an angle drawn in [0, 360) degrees about the origin.
"""

from __future__ import annotations

import argparse
import collections
import sys

import numpy as np


def draw(d: int) -> dict:
    """The raw scenario of draw ``d``."""
    from nodnav.scenario.transform import transform_points, transformed_world_raw

    rng = np.random.default_rng(d)
    n_rooms = int(rng.integers(3, 5))
    height = float(rng.uniform(4.0, 6.0))
    widths = rng.uniform(3.0, 5.0, n_rooms)
    lengths = rng.uniform(1.5, 3.0, n_rooms - 1)
    x, rooms, obstacles, passages = 0.0, [], [], []
    for k in range(n_rooms):
        rooms.append((x, x + widths[k]))
        x += widths[k]
        if k < n_rooms - 1:
            w = float(rng.uniform(0.6, 0.75))
            yc = float(rng.uniform(-height / 2 + 1.0, height / 2 - 1.0))
            obstacles += [[x, -height / 2, x + lengths[k], yc - w / 2], [x, yc + w / 2, x + lengths[k], height / 2]]
            passages.append(((x, yc), (x + lengths[k], yc), w))
            x += lengths[k]
    bounds = [0.0, -height / 2, x, height / 2]
    n_robots = int(rng.integers(3, 7))
    robots: list[dict] = []
    ends: dict[str, list[np.ndarray]] = {"origin": [], "destination": []}
    while len(robots) < n_robots:
        a, b = rng.choice(n_rooms, 2, replace=False)
        pts = {}
        for key, room in (("origin", rooms[a]), ("destination", rooms[b])):
            for _ in range(100):
                p = np.array([rng.uniform(room[0] + 0.5, room[1] - 0.5),
                              rng.uniform(-height / 2 + 0.5, height / 2 - 0.5)])
                if all(np.linalg.norm(p - q) >= 0.6 for q in ends[key]):
                    pts[key] = p
                    break
        if len(pts) == 2:
            for key in pts:
                ends[key].append(pts[key])
            robots.append({"origin": pts["origin"], "destination": pts["destination"]})
    angle = float(rng.uniform(0.0, 360.0))
    raw_world = {"bounds": bounds, "obstacles": obstacles}
    first = passages[0]
    world = transformed_world_raw(raw_world, first, angle, (0.0, 0.0))
    world["passages"] = [{"from": [float(c) for c in transform_points(np.asarray(s), angle, (0.0, 0.0))],
                          "to": [float(c) for c in transform_points(np.asarray(e), angle, (0.0, 0.0))], "width": w}
                         for s, e, w in passages]
    turned = [{key: [float(c) for c in transform_points(r[key], angle, (0.0, 0.0))] for key in r} for r in robots]
    return {"name": f"series-{d}", "world": world, "robots": turned, "time_limit": 40.0 + 15.0 * n_robots}


def main(argv: list[str] | None = None) -> int:
    """Run the draws and print one line each and a summary."""
    from nodnav.api import run_trial
    from nodnav.scenario.schema import scenario_from_dict

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=40)
    parser.add_argument("--first", type=int, default=1)
    parser.add_argument("--method", default="nod")
    args = parser.parse_args(argv)
    outcomes: collections.Counter = collections.Counter()
    for d in range(args.first, args.first + args.draws):
        s = scenario_from_dict(draw(d))
        result = run_trial(s, method=args.method, seed=d)
        outcomes[result.outcome] += 1
        print(f"draw {d}: {s.n_robots} robots, {len(s.world.passages)} passages: {result.outcome} at "
              f"{result.sim_time:.1f} s, closest {result.min_separation:.3f} m, {result.wall_time:.1f} s computing",
              flush=True)
    print(f"{args.method}: {dict(outcomes)} of {args.draws} draws")
    return 0


if __name__ == "__main__":
    sys.exit(main())
