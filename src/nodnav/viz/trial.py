"""Pictures of a finished trial, drawn from its :class:`~nodnav.sim.history.History` alone."""

from __future__ import annotations

import logging
import shutil
import subprocess
from pathlib import Path

import numpy as np
from PIL import Image
from matplotlib.patches import Circle

from nodnav.decision.strategies import order_label, passing_orders, strategy_label
from nodnav.sim.history import History
from nodnav.viz.scenario import draw_world, new_figure, robot_color

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
        ax.plot(*robot.destination, marker="x", color=color, markersize=8, markeredgewidth=2)
    if players and len(arrays["decision_times"]):
        d = max(0, int(np.searchsorted(arrays["decision_times"], arrays["times"][k], side="right")) - 1)
        for i, row in enumerate(arrays["players"][d]):
            for j in np.flatnonzero(row):
                ax.annotate("", xy=pos[k, j], xytext=pos[k, i],
                            arrowprops={"arrowstyle": "->", "color": robot_color(i), "lw": 1.2,
                                        "shrinkA": 6, "shrinkB": 6}, zorder=5)


def save_snapshots(history: History, path: str | Path, count: int = 4) -> Path:
    """The paper-style snapshot figure (Figs. 4 and 5).

    Top row: robots, their trajectories so far and their game players (arrows from a robot to
    each of its players) at ``count`` instants. Bottom row: for each robot, the probability of
    the strategy it currently selects, over time up to that instant; the legend names the
    strategy and its passing order.
    """
    arrays = history.arrays()
    scenario = history.scenario
    orders = passing_orders(scenario.n_robots)
    fig = new_figure(4.2 * count, 5.4)
    times = snapshot_times(history, count)
    for c, t in enumerate(times):
        k = min(int(np.searchsorted(arrays["times"], t - 1e-9)), len(arrays["times"]) - 1)
        ax = fig.add_subplot(2, count, c + 1)
        draw_world(ax, scenario.world, entrances=False)
        _draw_robots(ax, history, arrays, k)
        ax.set_title(f"t = {arrays['times'][k]:.1f} s", fontsize=9)
        ax.set_xlabel("")
        ax.set_ylabel("")
        bx = fig.add_subplot(2, count, count + c + 1)
        dts = arrays["decision_times"]
        upto = dts <= arrays["times"][k] + 1e-9
        if upto.any() and arrays["probabilities"].shape[-1]:
            d = int(np.flatnonzero(upto)[-1])
            for i in range(scenario.n_robots):
                j = int(arrays["strategies"][d, i])
                if j < 0:
                    continue
                bx.plot(dts[upto], arrays["probabilities"][upto, i, j], "-", color=robot_color(i), linewidth=1.5,
                        label=f"robot {i + 1}: {strategy_label(j)} {order_label(orders[j])}")
            bx.legend(fontsize=7, loc="lower right")
        bx.set_ylim(-0.02, 1.02)
        bx.set_xlim(0, max(times[-1], 1e-6))
        bx.set_xlabel("t [s]")
        if c == 0:
            bx.set_ylabel("probability of current strategy")
    fig.suptitle(f"{scenario.name} ({history.method}, seed {history.seed}): {history.outcome}", fontsize=10)
    fig.tight_layout()
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
    orders = passing_orders(scenario.n_robots)
    pos = arrays["positions"]
    fig = new_figure(7.0, 3.4)
    ax = fig.add_subplot(1, 1, 1)
    draw_world(ax, scenario.world, entrances=False)
    for i, robot in enumerate(scenario.robots):
        ax.plot(*robot.destination, marker="x", color=robot_color(i), markersize=8, markeredgewidth=2)
    ax.set_title(" ", fontsize=8)
    fig.tight_layout()
    canvas = fig.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    trails = [ax.plot([], [], "-", color=robot_color(i), linewidth=1.2, alpha=0.8, animated=True)[0]
              for i in range(scenario.n_robots)]
    discs = [ax.add_patch(Circle(pos[0, i], r.radius, facecolor=robot_color(i), edgecolor="k", zorder=4,
                                 animated=True)) for i, r in enumerate(scenario.robots)]
    title = ax.set_title("", fontsize=8, animated=True)
    has_opinions = len(arrays["decision_times"]) > 0 and arrays["probabilities"].shape[-1] > 0
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
                label = "  ".join(f"{i + 1}:{order_label(orders[j])}"
                                  for i, j in enumerate(arrays["strategies"][d]) if j >= 0)
        title.set_text(f"{scenario.name}  t = {arrays['times'][k]:4.1f} s   {label}")
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
