"""Drawing the world and a scenario the way the paper's configuration figure does."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon, Rectangle

from nodnav.scenario.maps import OccupancyMap
from nodnav.scenario.schema import Scenario
from nodnav.scenario.world import Passage, World
from nodnav.viz.text import set_title

#: Robot colours in the paper's order: robot 1 red, 2 blue, 3 green, 4 orange, then more.
ROBOT_COLORS = ("#d62728", "#1f77b4", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf")


def robot_color(k: int) -> str:
    """Colour of robot index ``k`` (0-based)."""
    return ROBOT_COLORS[k % len(ROBOT_COLORS)]


def new_figure(width: float, height: float) -> Figure:
    """A figure rendered by the Agg backend, independent of pyplot's global state."""
    fig = Figure(figsize=(width, height))
    FigureCanvasAgg(fig)
    return fig


def draw_map(ax: Axes, m: OccupancyMap, passages: Sequence[Passage] = ()) -> None:
    """An occupancy-grid map (walls grey, free space white) with its passages shaded and numbered."""
    ax.imshow(np.where(m.free, 1.0, 0.55), cmap="gray", vmin=0.0, vmax=1.0, origin="lower",
              extent=(m.bounds[0], m.bounds[2], m.bounds[1], m.bounds[3]), interpolation="nearest", zorder=0)
    for k, passage in enumerate(passages):
        ax.add_patch(Polygon(passage.outline(), closed=True, facecolor="#ffd54f", edgecolor="#b26a00",
                             linewidth=0.8, zorder=1))
        ax.annotate(str(k + 1), np.mean([passage.start, passage.end], axis=0), xytext=(3, 3),
                    textcoords="offset points", fontsize=6, color="#8a3b00", zorder=2)
    ax.set_aspect("equal")


def save_map_figure(m: OccupancyMap, passages: Sequence[Passage], path: str | Path) -> Path:
    """Write a figure of a map with its passages numbered."""
    x0, y0, x1, y1 = m.bounds
    fig = new_figure(9.0, max(3.0, 9.0 * (y1 - y0) / (x1 - x0)))
    ax = fig.add_subplot(1, 1, 1)
    draw_map(ax, m, passages)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    set_title(ax, f"{Path(m.path).name}: {len(passages)} single-file passages", 9)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    return Path(path)


def draw_world(ax: Axes, world: World, *, entrances: bool = True) -> None:
    """Walls (boxes and polygons) in grey, the passage shaded, entrances as small black diamonds; a
    world on a map draws the map's grid and numbers its passages, and so does any world with
    several passages (each passage's mouths as diamonds)."""
    x0, y0, x1, y1 = world.bounds
    ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="0.2", linewidth=1.5))
    if world.map_file:
        from nodnav.scenario.maps import read_map

        draw_map(ax, read_map(world.map_file), world.passages)
    for ox0, oy0, ox1, oy1 in world.obstacles[world.map_walls:]:
        ax.add_patch(Rectangle((ox0, oy0), ox1 - ox0, oy1 - oy0, facecolor="0.55", edgecolor="0.3"))
    for poly in world.polygons:
        ax.add_patch(Polygon(np.asarray(poly), closed=True, facecolor="0.55", edgecolor="0.3"))
    for passage in world.passages:
        ax.add_patch(Polygon(passage.outline(), closed=True, facecolor="#fff3c4", edgecolor="none", zorder=0))
    several = len(world.passages) > 1
    if several and not world.map_file:  # numbered as on a map (draw_map), for the per-passage figures
        for k, passage in enumerate(world.passages):
            ax.annotate(str(k + 1), np.mean([passage.start, passage.end], axis=0), xytext=(3, 3),
                        textcoords="offset points", fontsize=6, color="#8a3b00", zorder=2)
    if entrances:  # every passage's mouths (the paper's two entrances with one)
        ent = (np.asarray([m for g in world.passages for m in (g.start, g.end)]) if several
               else np.asarray(world.entrances))
        ax.plot(ent[:, 0], ent[:, 1], "kD", markersize=4, zorder=3)
    ax.set_xlim(x0 - 0.2, x1 + 0.2)
    ax.set_ylim(y0 - 0.2, y1 + 0.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_scenario(ax: Axes, scenario: Scenario, *, labels: bool = True) -> None:
    """Origins as coloured circles of the robot's size, destinations as X marks of the same colour."""
    draw_world(ax, scenario.world)
    for k, robot in enumerate(scenario.robots):
        color = robot_color(k)
        ax.add_patch(Circle(robot.origin, robot.radius, facecolor=color, edgecolor="k", alpha=0.85, zorder=4))
        ax.plot(*robot.destination, marker="x", color=color, markersize=10, markeredgewidth=2.5, zorder=4)
        if labels:
            ax.annotate(str(k + 1), robot.origin, ha="center", va="center", color="white", fontsize=8,
                        fontweight="bold", zorder=5)
    set_title(ax, scenario.name + (f"\n{scenario.description}" if scenario.description else ""), 8)


def scenario_figure(scenario: Scenario) -> Figure:
    """One scenario drawn in a figure 7 inches wide, made taller by the lines its title needs."""
    fig = new_figure(7.0, 3.2)
    ax = fig.add_subplot(1, 1, 1)
    draw_scenario(ax, scenario)
    lines = ax.title.get_text().count("\n") + 1
    fig.set_figheight(3.2 + 0.16 * max(0, lines - 2))  # a line of 8 pt text with its spacing
    fig.tight_layout()
    return fig


def save_scenario_figure(scenario: Scenario, path: str | Path) -> Path:
    """Write a PNG of one scenario."""
    scenario_figure(scenario).savefig(path, dpi=130)
    return Path(path)


def save_gallery(scenarios: list[Scenario], path: str | Path, columns: int = 2) -> Path:
    """Write a PNG with every scenario in a grid, like the paper's configuration figure."""
    rows = int(np.ceil(len(scenarios) / columns))
    fig = new_figure(6.0 * columns, 2.9 * rows)
    for k, scenario in enumerate(scenarios):
        ax = fig.add_subplot(rows, columns, k + 1)
        draw_scenario(ax, scenario)
        ax.set_xlabel("")
        ax.set_ylabel("")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return Path(path)
