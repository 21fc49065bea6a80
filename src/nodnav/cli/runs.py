"""The commands that compute one thing and show it: ``heatmap``, ``plan``, ``run``, ``replay``."""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

import numpy as np

from nodnav.cli.settings import add_set_option, scenario_with_options
from nodnav.cli.terminal import MAX_SEED, real, trial_summary_lines, whole
from nodnav.errors import NodnavError, shown
from nodnav.paths import output_dir, output_file, safe_filename


def _cmd_heatmap(args: argparse.Namespace) -> int:
    from nodnav.decision.heatmap import steady_state_selection, z_grid

    out = output_file(args.out) if args.out else None
    if not args.execute:
        return 0
    if not args.json and (args.grid > 41 or abs(args.u) > 200):
        print(f"integrating eq. (1) from {args.grid * args.grid} initial opinions (a minute or more for large "
              "|u| and grids)...", file=sys.stderr)
    result = steady_state_selection(args.u, z_grid(args.grid))
    if out:
        from nodnav.viz.heatmap import plot_heatmap

        plot_heatmap(result, out)
    if args.json:
        print(json.dumps({"u": args.u, "z_values": result.z_values.tolist(), "x11": result.x11.tolist()}))
    else:
        x = result.x11
        print(f"u = {args.u:g}: lim x11 ranges over [{x.min():.4f}, {x.max():.4f}] on a {args.grid}x{args.grid} grid"
              f"{'' if result.converged else ' (NOT converged: ' + result.reason + ')'}")
        if out:
            print(f"wrote {out}")
    return 0


def _parse_order(text: str, n: int) -> tuple[int, ...]:
    parts = text.split(",")
    if len(parts) != n or not all(re.fullmatch(r"\s*[0-9]{1,3}\s*", p) for p in parts):
        raise NodnavError(f"--order: expected the {n} robot numbers separated by commas, e.g. "
                          f"{','.join(str(k) for k in range(n, 0, -1))}; got {shown(text)}")
    order = tuple(int(k) - 1 for k in parts)
    if sorted(order) != list(range(n)):
        raise NodnavError(f"--order: expected a permutation of 1..{n} for this {n}-robot scenario, got {shown(text)}")
    return order


def _cmd_plan(args: argparse.Namespace) -> int:
    scenario = scenario_with_options(args)
    order = _parse_order(args.order, scenario.n_robots)
    out = output_file(args.out) if args.out else None
    if not args.execute:
        return 0
    from nodnav.geometry import min_pair_distance
    from nodnav.planning import PlanRequest, make_planner
    from nodnav.planning.base import corridor_entry_order

    planner = make_planner(scenario.planner, scenario.world)
    request = PlanRequest(world=scenario.world, positions=scenario.origins,
                          velocities=np.zeros_like(scenario.origins), destinations=scenario.destinations,
                          radii=scenario.radii, max_speeds=scenario.max_speeds, order=order,
                          max_accels=np.array([r.max_accel for r in scenario.robots], dtype=float))
    result = planner.plan(request)
    fine_times = np.arange(result.trajectory.times[0], result.trajectory.times[-1] + 1e-9, 0.02)
    summary = {
        "success": result.success,
        "reason": result.reason,
        "cost": result.cost if np.isfinite(result.cost) else None,
        "min_separation_m": min_pair_distance(result.trajectory.positions_at(fine_times)),
        "corridor_entry_order": [k + 1 for k in corridor_entry_order(scenario.world, result.trajectory)],
        "duration_s": result.trajectory.duration,
        "compute_time_ms": 1e3 * result.compute_time,
        "planner": scenario.planner.name,
    }
    if out:
        from nodnav.viz.plan import save_plan_figure

        save_plan_figure(scenario, result, out)
    if args.json:
        print(json.dumps(summary))
    else:
        status = "ok" if result.success else f"FAILED: {result.reason}"
        print(f"{scenario.name} order {args.order} with {summary['planner']}: {status}")
        if result.success:
            print(f"  cost {result.cost:.2f}, duration {result.trajectory.duration:.1f} s, "
                  f"closest approach {summary['min_separation_m']:.3f} m between centres, "
                  f"corridor entry order {','.join(map(str, summary['corridor_entry_order']))}, "
                  f"planned in {summary['compute_time_ms']:.1f} ms")
        if out:
            print(f"wrote {out}")
    return 0 if result.success else 1


def write_trial_outputs(result, out: Path) -> list[Path]:
    """History, snapshot figure and animation of a finished trial, into ``out``; the file names
    come from the scenario's name made safe (:func:`~nodnav.paths.safe_filename`)."""
    from nodnav.viz.trial import save_animation, save_snapshots

    out.mkdir(parents=True, exist_ok=True)
    h = result.history
    stem = f"{safe_filename(h.scenario.name)}-{safe_filename(h.method)}-seed{h.seed}"
    written = [h.save(out / f"{stem}.npz"), save_snapshots(h, out / f"{stem}-snapshots.png")]
    written += save_animation(h, out / f"{stem}.gif")
    return written


def _cmd_run(args: argparse.Namespace) -> int:
    from nodnav.errors import nearest_hint
    from nodnav.experiments.study import known_methods

    scenario = scenario_with_options(args)
    if args.method not in known_methods():
        raise NodnavError(f"--method: unknown method {shown(args.method)}"
                          f"{nearest_hint(args.method, known_methods(), 'methods')}")
    out = output_dir(args.out) if args.out else None
    if not args.execute:
        return 0
    from tqdm import tqdm

    from nodnav.sim.simulator import run_trial

    bar = None

    def progress(t: float, limit: float) -> None:
        nonlocal bar
        if bar is None:  # started after the first step, so compiling does not count towards the rate
            bar = tqdm(total=round(limit, 1), initial=round(t, 1), unit="sim s", delay=2.0, leave=False,
                       file=sys.stderr, bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} simulated s "
                       "[{elapsed}, at most {remaining} more]")
        elif t - bar.n >= 1.0 - 1e-9:  # redraw once per simulated second
            bar.update(t - bar.n)

    result = run_trial(scenario, args.method, args.seed, progress=None if args.json else progress)
    if bar is not None:
        bar.close()
    written = write_trial_outputs(result, out) if out else []
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print("\n".join(trial_summary_lines(result, scenario, args.method, args.seed)))
        for path in written:
            print(f"wrote {path}")
    return 0


def _cmd_replay(args: argparse.Namespace) -> int:
    from nodnav.sim.history import History

    history = History.load(args.history)
    out = output_dir(args.out)
    if not args.execute:
        return 0
    from nodnav.viz.trial import save_animation, save_snapshots

    stem = safe_filename(Path(args.history).stem)
    written = [save_snapshots(history, out / f"{stem}-snapshots.png")]
    if not args.no_animation:
        written += save_animation(history, out / f"{stem}.gif")
    for path in written:
        print(f"wrote {path}")
    return 0


def add_parsers(sub) -> None:
    """The subcommands of this module."""
    from nodnav.planning import PLANNERS
    from nodnav.sim import METHODS

    # Choices and their help come from the registries (plugins included).
    planners, methods = PLANNERS.help_text(), METHODS.help_text()
    p = sub.add_parser("heatmap", help="steady-state strategy selection of the pure NOD (Fig. 2a/2b)")
    p.add_argument("--u", type=real(-1000, 1000), required=True, help="attention parameter u (from -1000 to 1000)")
    p.add_argument("--grid", type=whole(2, 101), default=41, help="grid points per axis over [-10, 10] (default 41)")
    p.add_argument("--out", help="picture to write (.png, .pdf, .svg, ...)")
    p.add_argument("--json", action="store_true", help="print the grid as JSON")
    p.set_defaults(func=_cmd_heatmap)

    p = sub.add_parser("plan", help="plan a joint path for one passing order from the scenario's origins")
    p.add_argument("scenario", help="built-in name, YAML path, or FAMILY:SEED (e.g. mixed:17)")
    p.add_argument("--order", required=True, help="passing order as robot numbers, e.g. 2,1,3")
    p.add_argument("--planner", help=f"planner ({planners}; default: the scenario's; = --set planner.name=NAME)")
    add_set_option(p)
    p.add_argument("--out", help="picture to write (.png, .pdf, .svg, ...)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=_cmd_plan)

    p = sub.add_parser("run", help="simulate one trial of a scenario")
    p.add_argument("scenario", help="built-in name, YAML path, or FAMILY:SEED (e.g. mixed:17)")
    p.add_argument("--seed", type=whole(0, MAX_SEED), default=1, help="trial seed (default 1)")
    p.add_argument("--players", help="game players per robot: a number or 'all' (default: the scenario's; "
                   "= --set game_players=K)")
    p.add_argument("--init", choices=("zero", "distance"), help="initial opinions (default: the scenario's; "
                   "= --set opinion.init=MODE)")
    p.add_argument("--bias", help="bias per strategy, e.g. S3=150,S5=150 (default: the scenario's; "
                   "= --set opinion.bias={S3: 150, S5: 150})")
    p.add_argument("--u", type=float, help="attention parameter u (default: the scenario's; = --set opinion.u=U)")
    p.add_argument("--planner", help=f"planner ({planners}; default: the scenario's; = --set planner.name=NAME)")
    p.add_argument("--method", default="nod", help=f"navigation method, nod by default ({methods})")
    p.add_argument("--noise", type=float, help="observation noise standard deviation in m (default: the scenario's; "
                   "= --set sim.observation_noise=SIGMA)")
    add_set_option(p)
    p.add_argument("--out", help="directory for the history, snapshot figure and animation")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("replay", help="redraw the pictures of a saved trial history")
    p.add_argument("history", help="a .npz history written by 'nodnav run --out'")
    p.add_argument("--out", required=True, help="directory for the pictures")
    p.add_argument("--no-animation", action="store_true", help="only the snapshot figure")
    p.set_defaults(func=_cmd_replay)
