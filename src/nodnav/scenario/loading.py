"""Finding a scenario by what the user wrote: a built-in name, a YAML file, or a family's draw.

This sits above :mod:`nodnav.scenario.draws` (a ``FAMILY:SEED`` is drawn there), which builds
its scenarios with :func:`~nodnav.scenario.schema.scenario_from_dict`, so nothing cycles.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from nodnav.errors import nearest_hint, shown_path
from nodnav.scenario.draws import draw_spec
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.files import builtin_names, builtin_text, parse_yaml, read_yaml
from nodnav.scenario.maps import map_beside
from nodnav.scenario.schema import Scenario, apply_overrides, override_scenario


def load_scenario(spec: str | Path, overrides: Mapping[str, Any] | None = None,
                  labels: Mapping[str, str] | None = None) -> Scenario:
    """Load a scenario by built-in name (``3r-case2``), from a YAML file path, or drawn from a
    family as ``FAMILY:SEED`` (``mixed:17``, ``path/fam.yaml:17``; :mod:`nodnav.scenario.draws`).

    ``overrides`` (scenario keys as a file writes them, ``{"planner.name": "prm", "robots[1].radius":
    0.3}``; :mod:`nodnav.scenario.overrides`) are merged into the file's mapping before its one
    validation; a family's draw is drawn as without them (so it stays the same scenario) and they
    apply to it. ``labels`` names each override as the user typed it, for errors.
    """
    spec = str(spec)
    if spec in builtin_names():
        return apply_overrides(parse_yaml(builtin_text(spec), spec), spec, overrides, labels)
    path = Path(spec)
    try:
        exists = path.exists()
    except (OSError, ValueError):  # a name too long for the file system, or holding a NUL
        exists = False
    if not exists:
        drawn = draw_spec(spec)  # FAMILY:SEED, a generated scenario
        if drawn is not None:
            return override_scenario(drawn, overrides, labels)
        hint = nearest_hint(spec, builtin_names(), "built-in scenarios")
        raise ScenarioError(f"{shown_path(spec)}: no such built-in scenario or file{hint}", key=spec)
    return apply_overrides(map_beside(read_yaml(path), path.parent), spec, overrides, labels)
