"""The paper's Fig. 2a/2b: steady-state strategy selection over a grid of initial opinions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from nodnav.decision.heatmap import HeatmapResult
from nodnav.viz.scenario import new_figure

XLABEL = r"$z_{11}(0)$"
YLABEL = r"$z_{21}(0)$"
COLORBAR_LABEL = r"$\lim_{t\to\infty}\, x_{11}(t)$"


def heatmap_title(result: HeatmapResult) -> str:
    """The figure title: the attention ``u_i`` (and ``d``, ``eta`` when not the paper's 1)."""
    title = rf"$u_i = {result.u:g}$"
    if result.d != 1.0 or result.eta != 1.0:
        title += rf", $d_i = {result.d:g}$, $\eta = {result.eta:g}$"
    if not result.converged:
        title += " (not converged)"
    return title


def heatmap_figure(result: HeatmapResult) -> Figure:
    """A figure of ``lim x_11`` with ``z_11(0)`` across and ``z_21(0)`` up, colour range [0, 1].

    ``result.z_values`` must be increasing; cells are centred on them.
    """
    z = np.asarray(result.z_values, dtype=float)
    # Cell edges halfway between the (increasing) grid values, so any spacing is drawn faithfully.
    inner = 0.5 * (z[1:] + z[:-1])
    first = z[0] - (inner[0] - z[0] if z.size > 1 else 0.5)
    last = z[-1] + (z[-1] - inner[-1] if z.size > 1 else 0.5)
    edges = np.concatenate([[first], inner, [last]])
    fig = new_figure(4.2, 3.6)
    ax = fig.add_subplot()
    # x11[a, c] has z_11 along rows; pcolormesh wants z_21 along rows, hence the transpose.
    image = ax.pcolormesh(edges, edges, np.asarray(result.x11).T, cmap="viridis", vmin=0.0, vmax=1.0)
    ax.set_aspect("equal")
    ax.set_xlabel(XLABEL)
    ax.set_ylabel(YLABEL)
    ax.set_title(heatmap_title(result))
    fig.colorbar(image, ax=ax, label=COLORBAR_LABEL)
    fig.tight_layout()
    return fig


def plot_heatmap(result: HeatmapResult, path: str | Path) -> Path:
    """Write the heatmap of :func:`heatmap_figure` as a PNG to ``path`` and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    heatmap_figure(result).savefig(path, format="png", dpi=150)
    return path
