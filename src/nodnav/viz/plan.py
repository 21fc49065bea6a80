"""Drawing a planned joint path: each robot's path in its colour, the passing order visible."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodnav.decision.strategies import order_label
from nodnav.planning.base import PlanResult, corridor_entry_order
from nodnav.scenario.schema import Scenario
from nodnav.viz.scenario import draw_scenario, new_figure, robot_color
from nodnav.viz.text import set_title


def save_plan_figure(scenario: Scenario, result: PlanResult, path: str | Path) -> Path:
    """Write a PNG of the joint path.

    Paths are coloured by robot, with dots every second of plan time; the number in a white
    circle where a robot enters the corridor is its rank in the realised passing order.
    """
    fig = new_figure(7.5, 3.6)
    ax = fig.add_subplot(1, 1, 1)
    draw_scenario(ax, scenario, labels=True)
    traj = result.trajectory
    world = scenario.world
    step = max(1, int(round(1.0 / np.median(np.diff(traj.times))))) if len(traj.times) > 1 else 1
    for k in range(traj.n_robots):
        color = robot_color(k)
        p = traj.positions[:, k]
        ax.plot(p[:, 0], p[:, 1], "-", color=color, linewidth=1.6, zorder=3)
        ax.plot(p[::step, 0], p[::step, 1], ".", color=color, markersize=4, zorder=3)
    inside = world.in_corridor(traj.positions)
    for rank, k in enumerate(corridor_entry_order(world, traj), start=1):
        entry = traj.positions[int(inside[:, k].argmax()), k]
        ax.annotate(str(rank), entry, ha="center", va="center", fontsize=8, fontweight="bold", zorder=6,
                    color=robot_color(k), bbox={"boxstyle": "circle,pad=0.2", "fc": "white", "ec": robot_color(k)})
    status = "" if result.success else f"  FAILED: {result.reason}"
    set_title(ax, f"{scenario.name}: order {order_label(result.order_planned)}, duration "
              f"{traj.duration:.1f} s, cost {result.cost:.1f}{status}", 8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    return Path(path)
