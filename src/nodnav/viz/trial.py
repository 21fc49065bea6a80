"""Pictures of a finished trial, drawn from its :class:`~nodnav.sim.history.History` alone."""

from __future__ import annotations

import logging
import shutil
import subprocess
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.legend_handler import HandlerPatch
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, FancyArrowPatch, Rectangle
from matplotlib.transforms import blended_transform_factory
from PIL import Image

from nodnav.decision.strategies import order_label, strategy_index, strategy_label
from nodnav.sim.history import History
from nodnav.sim.metrics import per_passage
from nodnav.viz.scenario import draw_world, new_figure, robot_color
from nodnav.viz.text import set_suptitle, set_title, wrap_text

log = logging.getLogger(__name__)


def snapshot_times(history: History, count: int = 4) -> np.ndarray:
    """``count`` instants spread over the trial, the last one at its end."""
    end = history.times[-1]
    return np.linspace(end / count, end, count)


def _draw_robots(ax, history: History, arrays: dict, k: int, *, trail: bool = True, players: bool = True) -> None:
    scenario = history.scenario
    pos = arrays["positions"]
    for i, robot in enumerate(scenario.robots):
        color = robot_color(i)
        if trail:
            ax.plot(pos[: k + 1, i, 0], pos[: k + 1, i, 1], "-", color=color, linewidth=1.2, alpha=0.8)
        ax.add_patch(Circle(pos[k, i], robot.radius, facecolor=color, edgecolor="k", zorder=4))
        ax.annotate(str(i + 1), pos[k, i], ha="center", va="center", color="white", fontsize=7,
                    fontweight="bold", zorder=6)
        ax.plot(*robot.destination, marker="x", color=color, markersize=8, markeredgewidth=2)
    if players and len(arrays["decision_times"]):
        d = max(0, int(np.searchsorted(arrays["decision_times"], arrays["times"][k], side="right")) - 1)
        for i, row in enumerate(arrays["players"][d]):
            for j in np.flatnonzero(row):
                ax.annotate("", xy=pos[k, j], xytext=pos[k, i],
                            arrowprops={"arrowstyle": "->", "color": robot_color(i), "lw": 1.2,
                                        "shrinkA": 6, "shrinkB": 6}, zorder=5)


def _marks_legend(has_players: bool) -> tuple[list, list[str]]:
    """Proxy artists and labels explaining every mark of the snapshot panels."""
    handles = [Line2D([], [], marker="o", linestyle="none", markersize=10, markerfacecolor="0.5",
                      markeredgecolor="k"),
               Line2D([], [], color="0.4", linewidth=1.2),
               Line2D([], [], marker="x", linestyle="none", markersize=8, markeredgewidth=2, color="0.4"),
               Rectangle((0, 0), 1, 1, facecolor="#fff3c4", edgecolor="none"),
               Rectangle((0, 0), 1, 1, facecolor="0.55", edgecolor="0.3")]
    labels = ["robot at that time (number inside, drawn to scale)", "its path so far", "its destination",
              "corridor (one robot at a time)", "wall"]
    if has_players:
        handles.insert(3, FancyArrowPatch((0, 0), (1, 0), arrowstyle="->", color="0.3"))
        labels.insert(3, "game player: from a robot to each robot it reasons about (eq. 7)")
    return handles, labels


class _ArrowHandler(HandlerPatch):
    """Draws a legend entry for an arrow as an arrow."""

    def create_artists(self, legend, orig_handle, xdescent, ydescent, width, height, fontsize, trans):
        arrow = FancyArrowPatch((-xdescent, height / 2 - ydescent), (width - xdescent, height / 2 - ydescent),
                                arrowstyle="->", mutation_scale=10, color="0.3", lw=1.2)
        arrow.set_transform(trans)
        return [arrow]


def _order_colors(used: list[tuple[int, ...]]) -> dict[tuple[int, ...], tuple]:
    cmap = colormaps["tab20" if len(used) > 10 else "tab10"]
    return {o: cmap(k % cmap.N) for k, o in enumerate(used)}


def selected_orders(ranks: np.ndarray) -> list[list[tuple[int, ...]]]:
    """The order each robot selected at each decision, from ``ranks`` ``(D, N_r, N_r)``
    (:attr:`~nodnav.sim.history.History.ranks`): ``out[d][i]``, empty when it selected none."""
    return [[tuple(int(k) for k in np.argsort(row)[np.sort(row) >= 0]) for row in per] for per in ranks]


def order_name(order: tuple[int, ...], n_robots: int) -> str:
    """An order in the paper's notation; a full order also by its strategy name, ``S5 (3,1,2)``."""
    if len(order) == n_robots:
        return f"{strategy_label(strategy_index(order))} {order_label(order)}"
    return order_label(order)


def draw_opinion_panel(ax, history: History, arrays: dict, marks: np.ndarray) -> None:
    """Every robot's chosen passing order at every decision, in one panel.

    One band per robot (robot 1 on top); over each opinion period a bar whose colour is the
    order the robot selected (of its game: itself and its game players) and whose height is that
    order's probability (a full band is 1). A robot that switches between orders shows alternating
    colours; beside its band are the orders it chose and how often. ``marks`` are the snapshot
    times (dotted lines).
    """
    scenario = history.scenario
    n = scenario.n_robots
    dts, chosen = arrays["decision_times"], arrays["chosen"]
    selected = selected_orders(arrays["ranks"])
    end = float(arrays["times"][-1]) if len(arrays["times"]) else 1.0
    ax.set_xlim(0, max(end, 1e-6))
    ax.set_ylim(-0.6, n - 0.4)
    ax.set_yticks(range(n), [f"robot {n - r}" for r in range(n)])
    for r, label in enumerate(ax.get_yticklabels()):
        label.set_color(robot_color(n - 1 - r))
    ax.set_xlabel("time t [s]")
    for t in marks:
        ax.axvline(t, color="0.5", linestyle=":", linewidth=1.0)
    everything = [o for per in selected for o in per if o]
    if not len(dts) or not everything:
        ax.text(0.5, 0.5, f"method {history.method} chooses no passing order: no opinions to show",
                transform=ax.transAxes, ha="center", va="center", fontsize=9)
        return
    used = sorted(set(everything), key=lambda o: (-everything.count(o), o))
    colors = _order_colors(used)
    edges = np.append(dts, max(end, dts[-1] + history.scenario.opinion.T))
    no_probability = False
    for i in range(n):
        y = n - 1 - i
        ax.add_patch(Rectangle((0, y - 0.4), edges[-1], 0.8, facecolor="0.94", edgecolor="0.8", zorder=0))
        mine = [per[i] for per in selected]
        for d, order in enumerate(mine):
            if not order:
                continue
            p = chosen[d, i]
            full = not np.isfinite(p)
            no_probability |= full
            ax.add_patch(Rectangle((edges[d], y - 0.4), edges[d + 1] - edges[d], 0.8 * (1.0 if full else p),
                                   facecolor=colors[order], edgecolor="white", linewidth=0.3,
                                   hatch="//" if full else None, zorder=1))
        picked = [o for o in mine if o]
        if picked:
            counts = sorted(((picked.count(o), o) for o in set(picked)), key=lambda c: (-c[0], c[1]))
            text = ", ".join(f"{order_name(o, n)} {100 * c / len(picked):.0f} %"
                             for c, o in counts[:3]) + (" ..." if len(counts) > 3 else "")
            ax.text(1.005, y, text, transform=blended_transform_factory(ax.transAxes, ax.transData), fontsize=7,
                    va="center", color=robot_color(i))
    shown_used = used[:12]
    handles = [Rectangle((0, 0), 1, 1, facecolor=colors[o]) for o in shown_used]
    labels = [f"order {order_name(o, n)}" for o in shown_used]
    if len(used) > len(shown_used):
        handles.append(Rectangle((0, 0), 1, 1, facecolor="white"))
        labels.append(f"... {len(used) - len(shown_used)} more")
    ax.legend(handles, labels, title="chosen passing order", fontsize=7, title_fontsize=7,
              loc="upper left", bbox_to_anchor=(1.0, -0.02), frameon=False,
              ncol=1 if len(handles) <= 6 else 2)
    set_title(ax, "Chosen passing order of each robot at each decision (colour; beside: the orders it chose and how "
              "often), bar height = its probability (full band = 1)"
              + ("; hatched: the method gives no probability" if no_probability else ""), 8)


def passage_orders_text(history: History, arrays: dict | None = None) -> str:
    """With several passages, the order in which the robots crossed each (numbered as drawn;
    :func:`nodnav.sim.metrics.per_passage`), e.g. ``"; crossed passage 1: 1,3; passage 2: 2"``;
    empty with one passage (the figures keep the one-passage look)."""
    world = history.scenario.world
    if len(world.passages) < 2:
        return ""
    a = arrays if arrays is not None else history.arrays()
    orders = per_passage(a["times"], a["positions"], world)["passage_entry_orders"]
    return "; crossed " + "; ".join(f"passage {k + 1}: {','.join(map(str, o)) or 'none'}" for k, o in enumerate(orders))


def save_snapshots(history: History, path: str | Path, count: int = 4) -> Path:
    """The snapshot figure (the paper's Figs. 4 and 5), readable on its own.

    Top row: the robots (numbered), their paths so far and their game players (arrows from a
    robot to each of its players) at ``count`` instants, with a legend for every mark and axes
    in metres. Bottom: one panel with every robot's chosen passing order and its probability at
    every decision (:func:`draw_opinion_panel`), the snapshot instants dotted; methods that
    choose no passing order (``orca``) have no such panel.
    """
    arrays = history.arrays()
    scenario = history.scenario
    opinions = bool(len(arrays["decision_times"]) and (arrays["ranks"] >= 0).any())
    fig = new_figure(4.2 * count + 2.6, 6.6 if opinions else 3.2)
    fig.set_layout_engine("constrained")
    grid = (fig.add_gridspec(2, count, height_ratios=[1.0, 0.8 + 0.12 * scenario.n_robots]) if opinions
            else fig.add_gridspec(1, count))
    times = snapshot_times(history, count)
    has_players = bool(len(arrays["players"]) and arrays["players"].any())
    marks = []
    for c, t in enumerate(times):
        k = min(int(np.searchsorted(arrays["times"], t - 1e-9)), len(arrays["times"]) - 1)
        marks.append(float(arrays["times"][k]))
        ax = fig.add_subplot(grid[0, c])
        draw_world(ax, scenario.world, entrances=False)
        _draw_robots(ax, history, arrays, k)
        ax.set_title(f"t = {arrays['times'][k]:.1f} s", fontsize=9)
        if c:
            ax.set_ylabel("")
    if opinions:
        draw_opinion_panel(fig.add_subplot(grid[1, :]), history, arrays, np.asarray(marks))
    handles, labels = _marks_legend(has_players)
    fig.legend(handles, labels, loc="outside lower center", ncol=len(handles), fontsize=7, frameon=False,
               title="marks of the top row", title_fontsize=7, handler_map={FancyArrowPatch: _ArrowHandler()})
    set_suptitle(fig, f"{scenario.name}, method {history.method}, seed {history.seed}: {history.outcome}"
                 + ("" if opinions else f" (method {history.method} chooses no passing order: no opinions to show)")
                 + passage_orders_text(history, arrays), 10)
    fig.savefig(path, dpi=110)
    return Path(path)


def _write_mp4(frames: list[np.ndarray], path: Path, fps: int) -> None:
    """Encode RGB frames with the ffmpeg program (H.264, even dimensions)."""
    h, w = frames[0].shape[:2]
    cmd = ["ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
           "-r", str(fps), "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", str(path)]
    subprocess.run(cmd, input=b"".join(f.tobytes() for f in frames), check=True)


def save_animation(history: History, path: str | Path, fps: int = 10, stride: int = 2) -> list[Path]:
    """An animation of the trial as a GIF at ``path``, and an MP4 beside it when ffmpeg is available.

    ``stride`` control steps per frame; with the default 0.1 s step the GIF plays at twice real time.
    The world is rendered once; each frame only redraws the robots, their trails and the player
    arrows over it (blitting), which keeps a minute of simulation to a few seconds of drawing.
    """
    arrays = history.arrays()
    scenario = history.scenario
    pos = arrays["positions"]
    fig = new_figure(7.0, 3.4)
    ax = fig.add_subplot(1, 1, 1)
    draw_world(ax, scenario.world, entrances=False)
    for i, robot in enumerate(scenario.robots):
        ax.plot(*robot.destination, marker="x", color=robot_color(i), markersize=8, markeredgewidth=2)
    ax.set_title(" \n ", fontsize=8)  # room for a title of two lines
    fig.tight_layout()
    canvas = fig.canvas
    assert isinstance(canvas, FigureCanvasAgg)  # new_figure renders with Agg
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    trails = [ax.plot([], [], "-", color=robot_color(i), linewidth=1.2, alpha=0.8, animated=True)[0]
              for i in range(scenario.n_robots)]
    discs = [Circle(pos[0, i], r.radius, facecolor=robot_color(i), edgecolor="k", zorder=4, animated=True)
             for i, r in enumerate(scenario.robots)]
    for disc in discs:
        ax.add_patch(disc)
    title = ax.set_title("", fontsize=8, animated=True)
    width = 1.1 * ax.get_position().width * fig.get_figwidth()
    has_opinions = len(arrays["decision_times"]) > 0 and (arrays["ranks"] >= 0).any()
    selected = selected_orders(arrays["ranks"])
    steps = list(range(0, len(arrays["times"]), stride))
    if steps[-1] != len(arrays["times"]) - 1:
        steps.append(len(arrays["times"]) - 1)
    frames = []
    for k in steps:
        canvas.restore_region(background)
        artists = []
        for i in range(scenario.n_robots):
            trails[i].set_data(pos[: k + 1, i, 0], pos[: k + 1, i, 1])
            discs[i].center = pos[k, i]
            artists += [trails[i], discs[i]]
        label = ""
        if len(arrays["decision_times"]):
            d = max(0, int(np.searchsorted(arrays["decision_times"], arrays["times"][k], side="right")) - 1)
            for i, row in enumerate(arrays["players"][d]):
                for j in np.flatnonzero(row):
                    artists.append(ax.annotate("", xy=pos[k, j], xytext=pos[k, i], zorder=5, animated=True, arrowprops={
                        "arrowstyle": "->", "color": robot_color(i), "lw": 1.2, "shrinkA": 6, "shrinkB": 6}))
            if has_opinions:
                label = "  ".join(f"{i + 1}:{order_label(o)}" for i, o in enumerate(selected[d]) if o)
        title.set_text(wrap_text(f"{scenario.name}  t = {arrays['times'][k]:4.1f} s   {label}", width, 8, max_lines=2))
        for artist in artists + [title]:
            ax.draw_artist(artist)
        frames.append(np.asarray(canvas.buffer_rgba())[..., :3].copy())
        for artist in artists[2 * scenario.n_robots:]:
            artist.remove()
    path = Path(path)
    images = [Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=64) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0, optimize=False)
    written = [path]
    if shutil.which("ffmpeg"):
        mp4 = path.with_suffix(".mp4")
        _write_mp4(frames, mp4, fps)
        written.append(mp4)
    else:
        log.info("ffmpeg not found: wrote the GIF only")
    return written
