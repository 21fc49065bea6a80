"""Compare the PRM* planner's compiled edge check through the wall index with the full loop over
every wall, on the cached roadmaps of a map scenario (issue 20).

For each roadmap in the cache whose world has the scenario's map walls, every roadmap edge and
20,000 edges between random vertex pairs (most of them through walls) are checked both ways:
:func:`nodnav.planning.joint_validity._motions_ok` with the world's index and with an empty one
(the full loop). Prints the disagreements (none expected).

    .venv/bin/python tools/audit_map_joint_checks.py examples/building/building-one-door-8.yaml [MAX_ROADMAPS]
"""

from __future__ import annotations

import json
import sys

import numpy as np


def main(scenario: str, limit: int = 0, pairs: int = 20_000) -> int:
    from nodnav.planning.joint_validity import CompiledRules, _motions_ok, separation_thresholds
    from nodnav.planning.roadmap_cache import resolve_cache_dir
    from nodnav.scenario.loading import load_scenario

    world = load_scenario(scenario).world
    if world.wall_grid is None:
        print("the scenario has no map: its checks loop over every wall already")
        return 2
    rng = np.random.default_rng(0)
    total = checked = done = 0
    for path in sorted(resolve_cache_dir().glob("prm-*.npz")):
        with np.load(path) as z:
            key = json.loads(str(z["key"]))
            if key["world"].get("map_walls") != world.map_walls or len(key["world"]["obstacles"]) != len(
                    world.obstacles):
                continue
            vertices, edges = np.array(z["vertices"]), np.array(z["edges"])
        if limit and done >= limit:
            break
        done += 1
        radii, dirs = np.array(key["radii"]), np.array(key["directions"])
        rules = CompiledRules.of(world, radii, dirs, separation_thresholds(radii, key["margin"]))
        loop = rules.args[:-3] + (np.zeros(5), np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64))
        i, j = rng.integers(0, len(vertices), pairs), rng.integers(0, len(vertices), pairs)
        a = np.ascontiguousarray(np.concatenate([vertices[edges[:, 0]], vertices[i]]))
        b = np.ascontiguousarray(np.concatenate([vertices[edges[:, 1]], vertices[j]]))
        indexed, full = _motions_ok(a, b, *rules.args), _motions_ok(a, b, *loop)
        bad = np.flatnonzero(indexed != full)
        total += len(bad)
        checked += len(a)
        print(f"{path.name}: {len(edges)} roadmap edges + {pairs} random, {len(bad)} disagreements", flush=True)
        for k in bad[:3]:
            print("  ", a[k].tolist(), b[k].tolist(), "index", indexed[k], "loop", full[k])
    print(f"{checked} edges checked, {total} disagreements")
    return 1 if total else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 0))
