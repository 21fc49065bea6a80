"""One frame of a running trial as an RGB array, drawn as ``nodnav run``'s figures draw robots."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.patches import Circle, RegularPolygon

from nodnav.sim.simulator import Simulation
from nodnav.viz.scenario import draw_world, new_figure, robot_color


def render_frame(sim: Simulation, controlled: tuple[int, ...] = ()) -> np.ndarray:
    """The world, every robot as a disc of its colour and size (a person as a hexagon), its
    number inside (``*`` after it for a robot commanded from outside), its destination as an X,
    ``(H, W, 3)`` uint8."""
    s = sim.scenario
    fig = new_figure(7.0, 3.4)
    ax = fig.add_subplot(1, 1, 1)
    draw_world(ax, s.world, entrances=False)
    for i, robot in enumerate(s.robots):
        color = robot_color(i)
        p = sim.positions[i]
        if sim.pedestrians[i]:
            ax.add_patch(RegularPolygon(p, 6, radius=robot.radius, facecolor=color, edgecolor="k", zorder=4))
        else:
            ax.add_patch(Circle(p, robot.radius, facecolor=color, edgecolor="k", zorder=4))
        label = f"{i + 1}{'*' if i in controlled else ''}"
        ax.annotate(label, p, ha="center", va="center", color="white", fontsize=7, fontweight="bold", zorder=6)
        ax.plot(*robot.destination, marker="x", color=color, markersize=8, markeredgewidth=2)
    ax.set_title(f"{s.name}  t = {sim.t:4.1f} s", fontsize=8)
    fig.tight_layout()
    canvas = fig.canvas
    assert isinstance(canvas, FigureCanvasAgg)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()
