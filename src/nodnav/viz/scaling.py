"""Figures against the number of robots, one line per number of game players.

Used by ``nodnav bench scaling --out`` (cost of a decision, memory, speed) and by the report's
section on 5 to 8 robots (success with Wilson intervals, makespan, cost of a trial).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodnav.viz.report import SERIES_COLORS
from nodnav.viz.scenario import new_figure
from nodnav.viz.text import set_suptitle, set_title

MARKERS = ("o", "s", "^", "D", "v", "P")


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return path


def _ordered(labels) -> list[str]:
    """Numbers of game players in increasing order, ``all`` last."""
    return sorted(labels, key=lambda p: (p == "all", int(p) if p != "all" else 0))


def _lines(ax, series: dict[str, tuple[np.ndarray, np.ndarray]], *, log: bool, ylabel: str, title: str,
           errors: dict[str, tuple[np.ndarray, np.ndarray]] | None = None) -> None:
    """One line per series ``label -> (robot counts, values)``, NaN values left out; ``errors``
    gives (low, high) per series for error bars."""
    for m, (label, (x, y)) in enumerate(series.items()):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        ok = np.isfinite(y)
        if not ok.any():
            continue
        style = dict(color=SERIES_COLORS[m % len(SERIES_COLORS)], marker=MARKERS[m % len(MARKERS)], markersize=4,
                     linewidth=1.2, label=label)
        if errors and label in errors:
            lo, hi = (np.asarray(v, dtype=float)[ok] for v in errors[label])
            # Offset the series a little so that their intervals do not hide each other.
            shift = 0.06 * (m - (len(series) - 1) / 2)
            ax.errorbar(x[ok] + shift, y[ok], yerr=[y[ok] - lo, hi - y[ok]], capsize=2, elinewidth=0.9, **style)
        else:
            ax.plot(x[ok], y[ok], **style)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("robots $N_r$")
    ax.set_ylabel(ylabel)
    set_title(ax, title, 9)
    ax.grid(alpha=0.3, which="both" if log else "major")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.legend(fontsize=7, title="game players k", title_fontsize=7)


def plot_scaling_benchmark(bench: dict, path: str | Path) -> Path:
    """The four figures of ``nodnav bench scaling`` (``bench`` is its ``to_dict()``): CPU time
    and planner calls per decision, peak memory and real-time factor, against ``N_r``."""
    cells = [c for c in bench["cells"] if "cpu_mean_s" in c]
    labels = _ordered({c["players"] for c in bench["cells"]})

    def series(value) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        out = {}
        for p in labels:
            mine = [c for c in cells if c["players"] == p]
            out[p] = (np.array([c["n_robots"] for c in mine]), np.array([value(c) for c in mine], dtype=float))
        return out

    fig = new_figure(10.0, 7.0)
    panels = [
        (lambda c: 1e3 * c["cpu_mean_s"], True, "CPU time [ms]", "CPU time per decision (every robot deciding)"),
        (lambda c: c["planner_calls_mean"], True, "planner calls", "plan queries per decision (planner calls)"),
        (lambda c: c["peak_rss_bytes"] / 2**20, False, "peak memory [MiB]", "peak memory of a trial's worker"),
        (lambda c: c["realtime_factor"], False, "simulated / wall time", "real-time factor"),
    ]
    for k, (value, log, ylabel, title) in enumerate(panels):
        _lines(fig.add_subplot(2, 2, k + 1), series(value), log=log, ylabel=ylabel, title=title)
    seeds = ", ".join(map(str, bench.get("seeds", [])))
    set_suptitle(fig, f"nodnav bench scaling: head-on door crowds, nod with the fast planner, one core (seeds {seeds})",
                 10)
    fig.tight_layout()
    return _save(fig, path)


def plot_scaling_study(rows: list[dict], path: str | Path) -> Path:
    """Success (with its Wilson interval), makespan and wall time per trial against ``N_r``.

    ``rows`` hold ``n_robots``, ``players`` (label), ``rate``, ``low``, ``high`` (fractions),
    ``makespan`` (mean over successful trials, s) and ``wall`` (mean wall time of a trial, s).
    """
    labels = _ordered({str(r["players"]) for r in rows})

    def series(key: str, scale: float = 1.0):
        out = {}
        for p in labels:
            mine = sorted((r for r in rows if str(r["players"]) == p), key=lambda r: r["n_robots"])
            out[p] = (np.array([r["n_robots"] for r in mine]), scale * np.array([r[key] for r in mine], dtype=float))
        return out

    fig = new_figure(12.0, 3.6)
    rates = series("rate", 100.0)
    errors = {p: (series("low", 100.0)[p][1], series("high", 100.0)[p][1]) for p in labels}
    ax = fig.add_subplot(1, 3, 1)
    _lines(ax, rates, log=False, ylabel="success [%]", title="success (95 % Wilson interval)", errors=errors)
    ax.set_ylim(-3, 103)
    _lines(fig.add_subplot(1, 3, 2), series("makespan"), log=False, ylabel="makespan [s]",
           title="makespan of successful trials (mean)")
    _lines(fig.add_subplot(1, 3, 3), series("wall"), log=False, ylabel="wall time [s]",
           title="wall time of a trial on one core (mean)")
    fig.tight_layout()
    return _save(fig, path)
