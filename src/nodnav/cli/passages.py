"""The ``passages`` command: a map's single-file passages, for a map YAML or a scenario on a map."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from nodnav.errors import NodnavError, shown_path
from nodnav.paths import output_file


def _radius(text: str) -> float:
    try:
        r = float(text)
    except ValueError:
        r = float("nan")
    if not 0.01 <= r <= 5.0:
        raise argparse.ArgumentTypeError(f"expected a robot radius in metres from 0.01 to 5, got {text!r}")
    return r


def _scenario_robots(raw: dict, label: str) -> tuple[str, Any, list[float], list[tuple[Any, Any]]]:
    """The map, bounds, radii, origins and destinations a scenario file writes (not validated further)."""
    import numpy as np

    from nodnav.scenario.fields import mapping, number, point, vector

    world = mapping(raw.get("world"), "world")
    if not isinstance(world.get("map"), str):
        raise NodnavError(f"{label}: has no world.map; 'nodnav passages' reads a map YAML or a scenario on a map")
    defaults = mapping(raw.get("robot_defaults"), "robot_defaults")
    default_radius = number(defaults.get("radius", 0.2), "robot_defaults.radius")
    entries = raw.get("robots")
    if not isinstance(entries, list) or not entries:
        raise NodnavError(f"{label}: robots: expected a list of robots")
    radii, ends = [], []
    for k, e in enumerate(entries):
        e = mapping(e, f"robots[{k}]")
        radii.append(number(e.get("radius", default_radius), f"robots[{k}].radius"))
        ends.append((np.array(point(e.get("origin"), f"robots[{k}].origin")),
                     np.array(point(e.get("destination"), f"robots[{k}].destination"))))
    bounds = vector(world["bounds"], 4, "world.bounds") if "bounds" in world else None
    return world["map"], bounds, radii, ends


def _cmd_passages(args: argparse.Namespace) -> int:
    from nodnav.scenario.files import read_yaml
    from nodnav.scenario.maps import map_beside
    from nodnav.scenario.passage_finding import map_passages

    path = Path(args.file)
    raw = read_yaml(path, "map or scenario")
    label = shown_path(path)
    if isinstance(raw, dict) and "image" in raw:
        if args.radius is None:
            raise NodnavError("--radius: give the robots' radius (m) for a map; a scenario gives its own")
        result = map_passages(str(path), [args.radius, args.radius], key=label)
    elif isinstance(raw, dict):
        where, bounds, radii, ends = _scenario_robots(map_beside(raw, path.parent), label)
        if args.radius is not None:
            radii = [args.radius] * len(radii)
        result = map_passages(where, radii, ends, key="world.map", bounds=bounds)
    else:
        raise NodnavError(f"{label}: expected a map YAML (image, resolution, origin) or a scenario on a map")
    out = output_file(args.out) if args.out else None
    if not args.execute:
        return 0
    m = result.map
    rows, cols = m.shape
    print(f"{shown_path(m.path)}: {cols} x {rows} cells of {m.resolution:g} m, {len(m.walls)} wall boxes; "
          f"single file where one robot fits ({result.one:g} m) and two cannot pass abreast "
          f"({2 * result.abreast:g} m): {len(result.found)} passages")
    for k, f in enumerate(result.found):
        users = result.used_by.get(k)
        tail = f", used by robots {', '.join(str(i + 1) for i in users)}" if users else ""
        joins = "" if f.joins_regions else ", its two sides also joined by wide space"
        print(f"{k + 1:4d}  {f.describe()}{joins}{tail}")
    if out is not None:
        from nodnav.viz.scenario import save_map_figure

        print(f"wrote {save_map_figure(m, [f.passage for f in result.found], out)}")
    return 0


def add_parsers(sub) -> None:
    """The subcommands of this module."""
    p = sub.add_parser("passages", help="list a map's single-file passages (a map YAML or a scenario on a map)")
    p.add_argument("file", help="map YAML (ROS map_server format) or scenario YAML with world.map")
    p.add_argument("--radius", type=_radius, help="robot radius (m); required for a map, else the scenario's")
    p.add_argument("--out", help="also draw the map with its passages numbered (.png, .pdf, .svg, ...)")
    p.set_defaults(func=_cmd_passages)
