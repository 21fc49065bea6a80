"""Figures of the evaluation report: rates with intervals, strategy frequencies, the closed-loop Fig. 2c."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodnav.viz.scenario import new_figure
from nodnav.viz.text import set_suptitle, set_title

#: Bar colours of the series of a grouped bar chart (colour-blind safe, Okabe-Ito).
SERIES_COLORS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000")


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, format="png", dpi=120)
    return path


def plot_rate_bars(groups: list[str], series: list[str], rates: np.ndarray, path: str | Path, *,
                   title: str = "", ylabel: str = "success rate [%]") -> Path:
    """Grouped bars of rates with their intervals as error bars, one group per entry of ``groups``.

    ``rates`` ``(len(groups), len(series), 3)`` holds (rate, low, high) as fractions; NaN rows are
    left out (no bar, so a missing cell is never drawn as 0 %).
    """
    rates = np.asarray(rates, dtype=float)
    if rates.shape != (len(groups), len(series), 3):
        raise ValueError(f"rates must be ({len(groups)}, {len(series)}, 3), got {rates.shape}")
    fig = new_figure(min(13.0, max(6.0, 0.25 * len(groups) * len(series) + 3.0)), 3.8)
    ax = fig.add_subplot()
    width = 0.8 / max(1, len(series))
    x = np.arange(len(groups))
    for b, name in enumerate(series):
        r, lo, hi = (100 * rates[:, b, c] for c in range(3))
        ok = np.isfinite(r)
        pos = x[ok] - 0.4 + width * (b + 0.5)
        color = SERIES_COLORS[b % len(SERIES_COLORS)]
        ax.bar(pos, r[ok], width * 0.92, color=color, label=name)
        # A marker at the rate keeps a 0 % bar visible.
        ax.errorbar(pos, r[ok], yerr=[r[ok] - lo[ok], hi[ok] - r[ok]], fmt="_", color="0.2", elinewidth=0.9,
                    capsize=2)
    ax.set_xticks(x, groups, rotation=30 if len(groups) > 6 else 0, ha="right" if len(groups) > 6 else "center",
                  fontsize=8)
    ax.set_ylim(0, 105)
    ax.set_ylabel(ylabel)
    ax.grid(axis="y", alpha=0.3)
    # Beside the axes, so that it never hides a bar.
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
    if title:
        set_title(ax, title, 9)
    fig.tight_layout()
    return _save(fig, path)


def plot_strategy_frequencies(rows, paper: list[tuple[float, ...]], labels: list[str], path: str | Path, *,
                              title: str = "") -> Path:
    """One panel per row of a strategy table: the paper's percentages beside ours with 95 % intervals.

    ``rows`` are :class:`~nodnav.experiments.analysis.StrategyFrequencies`, ``paper`` the paper's
    percentages per row, ``labels`` each row's name.
    """
    fig = new_figure(4.2 * max(1, len(rows)), 3.4)
    for c, (freq, ref, label) in enumerate(zip(rows, paper, labels)):
        ax = fig.add_subplot(1, len(rows), c + 1)
        x = np.arange(len(ref))
        ax.bar(x - 0.2, ref, 0.4, color="0.65", label="paper")
        if freq.realised:
            sh = freq.share
            r, lo, hi = 100 * np.asarray(sh.rate), 100 * np.asarray(sh.low), 100 * np.asarray(sh.high)
            ax.bar(x + 0.2, r, 0.4, color=SERIES_COLORS[0], label=f"ours ({freq.realised} orders)")
            ax.errorbar(x + 0.2, r, yerr=[r - lo, hi - r], fmt="none", ecolor="0.2", elinewidth=0.9, capsize=2)
        ax.set_xticks(x, [f"S{j + 1}" for j in x])
        ax.set_ylim(0, 100)
        set_title(ax, label, 9)
        ax.grid(axis="y", alpha=0.3)
        if c == 0:
            ax.set_ylabel("share of realised orders [%]")
        ax.legend(fontsize=7, loc="upper left")
    if title:
        set_suptitle(fig, title, 10)
    fig.tight_layout()
    return _save(fig, path)


def plot_closed_loop_grid(grid, path: str | Path) -> Path:
    """Fig. 2c: share of trials realising S1 over ``z_11(0)`` (across) and ``z_21(0)`` (up).

    ``grid`` is a :class:`~nodnav.experiments.analysis.ClosedLoopGrid`; each cell is labelled with
    ``S1 trials / realised orders``, and cells without a realised order are grey.
    """
    z = np.asarray(grid.z_values, dtype=float)
    inner = 0.5 * (z[1:] + z[:-1])
    step = (inner[0] - z[0]) if z.size > 1 else 0.5
    edges = np.concatenate([[z[0] - step], inner, [z[-1] + (z[-1] - inner[-1] if z.size > 1 else 0.5)]])
    fig = new_figure(4.4, 3.6)
    ax = fig.add_subplot()
    ax.set_facecolor("0.8")
    # fraction[a, c] has z_11 along rows; pcolormesh wants z_21 along rows, hence the transpose.
    frac = np.ma.masked_invalid(grid.fraction.T)
    image = ax.pcolormesh(edges, edges, frac, cmap="viridis", vmin=0.0, vmax=1.0)
    for a, z11 in enumerate(z):
        for c, z21 in enumerate(z):
            if grid.trials[a, c]:
                f = grid.fraction[a, c]
                ax.text(z11, z21, f"{grid.s1[a, c]}/{grid.realised[a, c]}", ha="center", va="center", fontsize=6,
                        color="w" if not np.isfinite(f) or f < 0.6 else "k")
    ax.set_aspect("equal")
    ax.set_xlabel(r"$z_{11}(0)$")
    ax.set_ylabel(r"$z_{21}(0)$")
    ax.set_title(rf"closed loop, $u_i = {grid.u:g}$", fontsize=10)
    fig.colorbar(image, ax=ax, label="share of trials realising S1 = (1,2)")
    fig.tight_layout()
    return _save(fig, path)
