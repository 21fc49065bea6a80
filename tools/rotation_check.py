"""Turn and move every built-in scenario and compare each trial with the original (issue 20).

    .venv/bin/python tools/rotation_check.py                      # every built-in, 30 90 135 180 degrees
    .venv/bin/python tools/rotation_check.py --sides 24 3r-case4  # controller polygons of 24 sides
    .venv/bin/python tools/rotation_check.py --perturb 1e-9       # unturned, origins moved by 1e-9 m

Prints one line per (scenario, angle): outcomes, entry orders and whether they match (``same``,
``symmetric`` when robots that are mirror images of each other swap places, or ``different``),
the time up to which the trajectories agree within 1e-6 m, the largest and the mean distance
between them, and the makespan difference (see :mod:`nodnav.sim.rotation`). Exit code 1 when
any outcome or order differs.
"""

from __future__ import annotations

import argparse
import sys

ANGLES = (30.0, 90.0, 135.0, 180.0)
SHIFT = (1.5, -2.0)


def main() -> int:
    import nodnav
    from nodnav.scenario.files import builtin_names
    from nodnav.sim.rotation import compare_perturbed, compare_rotated

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", help="built-in names (default: all)")
    ap.add_argument("--angles", type=float, nargs="+", default=ANGLES)
    ap.add_argument("--sides", type=int, default=0,
                    help="speed and acceleration polygon sides of the controller (0: the scenario's)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--perturb", type=float, default=0.0,
                    help="instead of turning, move every origin by (EPS, -EPS) m: the rounding floor")
    args = ap.parse_args()
    bad = 0
    for name in args.scenarios or builtin_names():
        s = nodnav.load_scenario(name)
        if args.sides:
            s = s.with_overrides(**{"controller.speed_polygon_sides": args.sides,
                                    "controller.accel_polygon_sides": args.sides})
        for angle in [float("nan")] if args.perturb else args.angles:
            c = (compare_perturbed(s, args.perturb, seed=args.seed) if args.perturb
                 else compare_rotated(s, angle, SHIFT, seed=args.seed))
            bad += not c.agrees
            print(f"{name:10s} {angle:5.0f}  {c.outcomes[0]}/{c.outcomes[1]}  {c.entry_orders[0]} {c.entry_orders[1]} "
                  f"{c.order_match:9s} same until {c.same_until:5.1f} s  max {c.max_distance:.2e} m  "
                  f"mean {c.mean_distance:.2e} m  "
                  f"makespan {c.makespan_difference:+.2f} s", flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
