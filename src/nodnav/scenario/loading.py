"""Finding a scenario by what the user wrote: a built-in name, a YAML file, or a family's draw.

This sits above :mod:`nodnav.scenario.draws` (a ``FAMILY:SEED`` is drawn there), which builds
its scenarios with :func:`~nodnav.scenario.schema.scenario_from_dict`, so nothing cycles.
"""

from __future__ import annotations

from pathlib import Path

from nodnav.errors import nearest_hint, shown_path
from nodnav.scenario.draws import draw_spec
from nodnav.scenario.fields import ScenarioError
from nodnav.scenario.files import builtin_names, builtin_text, parse_yaml, read_yaml
from nodnav.scenario.schema import Scenario, scenario_from_dict


def load_scenario(spec: str | Path) -> Scenario:
    """Load a scenario by built-in name (``3r-case2``), from a YAML file path, or drawn from a
    family as ``FAMILY:SEED`` (``mixed:17``, ``path/fam.yaml:17``; :mod:`nodnav.scenario.draws`)."""
    spec = str(spec)
    if spec in builtin_names():
        return scenario_from_dict(parse_yaml(builtin_text(spec), spec), spec)
    path = Path(spec)
    try:
        exists = path.exists()
    except (OSError, ValueError):  # a name too long for the file system, or holding a NUL
        exists = False
    if not exists:
        drawn = draw_spec(spec)  # FAMILY:SEED, a generated scenario
        if drawn is not None:
            return drawn
        hint = nearest_hint(spec, builtin_names(), "built-in scenarios")
        raise ScenarioError(f"{shown_path(spec)}: no such built-in scenario or file{hint}", key=spec)
    return scenario_from_dict(read_yaml(path), spec)
