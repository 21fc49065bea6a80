"""A gallery of a family's draws: many generated scenarios side by side, each at its own scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import Passage
from nodnav.viz.scenario import draw_scenario, new_figure
from nodnav.viz.text import set_suptitle, set_title


def short_title(scenario: Scenario) -> str:
    """``mixed:17`` and what the draw holds (the part of the description after the family's source)."""
    what = scenario.description.split("): ", 1)[-1] if "): " in scenario.description else scenario.description
    return f"{scenario.name}\n{what}"


def save_family_gallery(title: str, scenarios: list[Scenario], path: str | Path, columns: int = 3,
                        more_passages: list[list[Passage]] | None = None) -> Path:
    """Write a PNG with every scenario in a grid under ``title``: origins as discs, destinations as crosses.

    ``more_passages[k]``: passages of scenario k beyond its world's one, shaded like it (floor
    plans with several passages, drawn while a world holds one)."""
    from matplotlib.patches import Polygon

    columns = max(1, min(columns, len(scenarios)))
    rows = int(np.ceil(len(scenarios) / columns))
    fig = new_figure(5.2 * columns, 3.2 * rows + 0.5)
    for k, scenario in enumerate(scenarios):
        ax = fig.add_subplot(rows, columns, k + 1)
        draw_scenario(ax, scenario)
        for passage in (more_passages[k] if more_passages else []):
            ax.add_patch(Polygon(passage.outline(), closed=True, facecolor="#fff3c4", edgecolor="none", zorder=0))
        set_title(ax, short_title(scenario), 8)
        ax.set_xlabel("x [m]", fontsize=7)
        ax.set_ylabel("y [m]", fontsize=7)
        ax.tick_params(labelsize=7)
    set_suptitle(fig, title, 10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return Path(path)
