"""The commands about scenarios: ``scenarios``, ``show``, ``families``, ``generate``."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import cast

from nodnav.cli.settings import add_set_option, overrides_of
from nodnav.cli.terminal import plural
from nodnav.errors import NodnavError
from nodnav.paths import output_file


def _cmd_scenarios(args: argparse.Namespace) -> int:
    from nodnav.scenario.files import builtin_names
    from nodnav.scenario.loading import load_scenario

    for name in builtin_names():
        s = load_scenario(name)
        print(f"{name:10s} {plural(s.n_robots, 'robot')}  {s.description}")
    return 0


def _cmd_show(args: argparse.Namespace) -> int:
    from nodnav.scenario.families import is_family
    from nodnav.scenario.files import builtin_names

    if is_family(args.scenario):
        return _show_family(args)
    if args.seed is not None or args.count is not None:
        raise NodnavError(f"--seed and --count draw from a family; {args.scenario!r} is a scenario "
                          "(list the families with 'nodnav families')")
    if _is_map(args.scenario):
        return _show_map(args)
    names = builtin_names() if args.scenario == "all" else [args.scenario]
    overrides, labels = overrides_of(args)
    scenarios = [_with_settings(n, overrides, labels, len(names) > 1) for n in names]
    out = output_file(args.out)
    if not args.execute:
        return 0
    from nodnav.viz.scenario import save_gallery, save_scenario_figure

    path = save_gallery(scenarios, out) if args.scenario == "all" else save_scenario_figure(scenarios[0], out)
    print(f"wrote {path}")
    return 0


def _is_map(spec: str) -> bool:
    """Whether ``spec`` names a map YAML (ROS map_server: it has an image) rather than a scenario."""
    path = Path(spec)
    try:
        if path.suffix.lower() not in (".yaml", ".yml") or not path.is_file() or path.stat().st_size > 100_000:
            return False
        import yaml

        data = yaml.safe_load(path.read_text())
    except (OSError, ValueError, UnicodeDecodeError, yaml.YAMLError):
        return False
    return isinstance(data, dict) and "image" in data and "robots" not in data


def _show_map(args: argparse.Namespace) -> int:
    """A map YAML: the map with its passages for two robots of the default radius (0.2 m)."""
    from nodnav.scenario.params import RobotSpec
    from nodnav.scenario.passage_finding import map_passages

    radius = cast(float, RobotSpec.__dataclass_fields__["radius"].default)
    result = map_passages(args.scenario, [radius, radius], key=args.scenario)
    out = output_file(args.out)
    if not args.execute:
        return 0
    from nodnav.viz.scenario import save_map_figure

    print(f"wrote {save_map_figure(result.map, [f.passage for f in result.found], out)} "
          f"(passages for robots of radius {radius:g} m; 'nodnav passages FILE --radius R' for others)")
    return 0


def _with_settings(name: str, overrides: dict, labels: dict, several: bool):
    """Scenario ``name`` with the ``--set`` settings; in a gallery an error also names the scenario."""
    from nodnav.scenario.fields import ScenarioError
    from nodnav.scenario.loading import load_scenario

    try:
        return load_scenario(name, overrides, labels)
    except ScenarioError as exc:
        if several and overrides:
            raise ScenarioError(f"{exc} (in {name})", key=exc.key) from None
        raise


def _first_seed(value: int | None) -> int:
    seed = 1 if value is None else value
    if seed < 0:
        raise NodnavError(f"--seed: expected a whole number >= 0, got {seed}")
    return seed


def _show_family(args: argparse.Namespace) -> int:
    from nodnav.scenario.families import load_family
    from nodnav.scenario.fields import ScenarioError
    from nodnav.scenario.schema import override_scenario
    from nodnav.viz.family import save_family_gallery

    family = load_family(args.scenario)
    if Path(args.out).suffix.lower() != ".png":
        raise NodnavError(f"--out: the gallery is a PNG image; give a file name ending in .png, got {args.out!r}")
    seed, count = _first_seed(args.seed), 6 if args.count is None else args.count
    if not 1 <= count <= 60:
        raise NodnavError(f"--count: expected a whole number in 1..60 for a gallery, got {count}")
    overrides, labels = overrides_of(args)
    scenarios, more = [], []
    for s in range(seed, seed + count):
        try:
            scenario, extra = _drawable(family, s)
            scenarios.append(override_scenario(scenario, overrides, labels))
            more.append(extra)
        except ScenarioError as exc:
            raise ScenarioError(f"{exc} (in {family.name}:{s})", key=exc.key) from None
    if not args.execute:
        return 0
    title = (f"family {family.name}, draws {seed}..{seed + count - 1}: origins (discs, numbered) and destinations "
             "(crosses)")
    print(f"wrote {save_family_gallery(title, scenarios, args.out, more_passages=more)}")
    return 0


def _drawable(family, seed: int):
    """Draw ``seed`` of ``family`` for a picture, and the passages beyond the first of a floor plan
    with several (the scenario keeps one while a world holds one; they are shaded alike)."""
    from nodnav.scenario.building_family import BuildingFamily
    from nodnav.scenario.draws import draw, draw_building
    from nodnav.scenario.schema import scenario_from_dict
    from nodnav.scenario.world import Passage

    if not isinstance(family, BuildingFamily):
        return draw(family, seed), []
    mapping = draw_building(family, seed)
    passages = mapping["world"]["passages"]
    one = {**mapping, "world": {**mapping["world"], "passages": passages[:1]}}
    extra = [Passage(tuple(p["from"]), tuple(p["to"]), p["width"]) for p in passages[1:]]
    return scenario_from_dict(one, mapping["name"]), extra


def _cmd_families(args: argparse.Namespace) -> int:
    from nodnav.scenario.families import builtin_families, load_family

    for name in builtin_families():
        f = load_family(name)
        print(f"{name:11s} {f.count[0]}-{f.count[1]} robots  {f.description}")
    return 0


def _cmd_generate(args: argparse.Namespace) -> int:
    from nodnav.scenario.draws import write_draws
    from nodnav.scenario.families import load_family

    if not 1 <= args.count <= 100_000:
        raise NodnavError(f"--count: expected a whole number in 1..100000, got {args.count}")
    family = load_family(args.family)
    if args.map is not None or args.resolution is not None:
        return _generate_map(args, family)
    if args.out is None:
        raise NodnavError("--out: give the directory for the scenario files (or --map FILE.yaml for a floor plan)")
    written = write_draws(family, _first_seed(args.seed), args.count, args.out)
    print(f"wrote {len(written)} scenario files to {args.out} ({written[0].name} .. {written[-1].name})")
    return 0


def _generate_map(args: argparse.Namespace, family) -> int:
    """``--map``: one floor plan of a building family as a map_server map, and a scenario using it."""
    from nodnav.scenario.building_family import BuildingFamily
    from nodnav.scenario.building_map import RESOLUTION, write_building
    from nodnav.scenario.draws import draw_building

    if not isinstance(family, BuildingFamily):
        raise NodnavError(f"--map: family {family.name!r} draws a corridor, not a floor plan; use a building "
                          "family (e.g. building)")
    if args.map is None:
        raise NodnavError("--resolution: applies to a floor plan written with --map FILE.yaml; give --map")
    if args.count != 1:
        raise NodnavError(f"--count: --map writes one floor plan; give --count 1 (got {args.count})")
    seed = _first_seed(args.seed)
    resolution = RESOLUTION if args.resolution is None else args.resolution
    map_path, scenario_path = write_building(draw_building(family, seed), args.map, args.out, resolution)
    print(f"wrote the floor plan {map_path} (+ {map_path.with_suffix('.pgm').name}, {resolution:g} m cells) "
          f"and the scenario {scenario_path}")
    return 0


def add_parsers(sub) -> None:
    """The subcommands of this module."""
    p = sub.add_parser("scenarios", help="list the built-in scenarios")
    p.set_defaults(func=_cmd_scenarios)

    p = sub.add_parser("show", help="draw a scenario (or 'all' for the gallery, or a family's draws)")
    p.add_argument("scenario", help="built-in name, YAML path, FAMILY:SEED, 'all', or a family (a gallery of draws)")
    p.add_argument("--out", required=True, help="picture to write (.png, .pdf, .svg, ...; a family's gallery: .png)")
    p.add_argument("--seed", type=int, help="family only: first draw (default 1)")
    p.add_argument("--count", type=int, help="family only: number of draws (default 6)")
    add_set_option(p)
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("families", help="list the built-in scenario families")
    p.set_defaults(func=_cmd_families)

    p = sub.add_parser("generate", help="write scenario files drawn from a family")
    p.add_argument("family", help="built-in family name or family YAML path")
    p.add_argument("--seed", type=int, default=1, help="first draw (default 1)")
    p.add_argument("--count", type=int, default=1, help="number of draws: seeds N..N+K-1 (default 1)")
    p.add_argument("--out", help="directory for the scenario files (FAMILY-SEED.yaml); with --map, default "
                   "the map's folder")
    p.add_argument("--map", help="building families: write the floor plan as a ROS map_server map FILE.yaml "
                   "(+ FILE.pgm) and a scenario using it")
    p.add_argument("--resolution", type=float, help="with --map: metres per cell (default 0.02)")
    p.set_defaults(func=_cmd_generate)
