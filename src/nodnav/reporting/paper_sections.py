"""The report's sections on the paper's own results: success rates (Fig. 3), Tables I and II, Fig. 2."""

from __future__ import annotations

import numpy as np

from nodnav.decision.heatmap import steady_state_selection, z_grid
from nodnav.decision.strategies import order_label, passing_orders
from nodnav.experiments.analysis import (
    closed_loop_grid,
    paper_inside,
    pooled,
    rate_cells,
    sign_rule_agreement,
    table_rows,
)
from nodnav.experiments.paper import (
    NEAR_ALL_MARGIN,
    PAPER_CLAIMED_SETS,
    PAPER_NEAR_ALL,
    STUDY_FIG2C,
    STUDY_SUCCESS,
)
from nodnav.experiments.statistics import fmt_rate, newcombe_difference, wilson_interval
from nodnav.experiments.store import OUTCOMES
from nodnav.reporting.document import ReportDocument
from nodnav.reporting.markdown import md_table
from nodnav.viz.heatmap import plot_heatmap
from nodnav.viz.report import plot_closed_loop_grid, plot_rate_bars, plot_strategy_frequencies


def section_success(rep: ReportDocument) -> None:
    """Fig. 3: success rates per scenario and number of game players, against the paper's claims."""
    rep.add("## Success rates (Fig. 3)", "",
            "Every built-in scenario with every number of game players per robot, zero initial opinions, no "
            "bias, NOD with the fast planner. The paper reports 0 % without game players and success \"close to "
            "100 %\" with any number of them (it gives no per-cell numbers).")
    if not rep.has(STUDY_SUCCESS):
        rep.absent(STUDY_SUCCESS, "Run `nodnav reproduce` to add it.")
        return
    planners = sorted({r for (r,) in rep.store.outcome_counts(by=("planner",), study=STUDY_SUCCESS)})
    planner = "fast" if "fast" in planners else planners[0]
    cells = rate_cells(rep.store, STUDY_SUCCESS, by=("n_robots", "scenario", "players"), method="nod", planner=planner)
    if not cells:
        rep.absent(STUDY_SUCCESS, "It holds no trial of the nod method.")
        return
    scenarios = sorted({c.key[:2] for c in cells})
    max_players = max(c.key[2] for c in cells)
    by = {c.key: c for c in cells}
    rates = np.full((len(scenarios), max_players + 1, 3), np.nan)
    table = []
    for a, (n_r, s) in enumerate(scenarios):
        row = [s]
        for k in range(max_players + 1):
            cell = by.get((n_r, s, k))
            if cell is None:
                row.append("")
                continue
            iv = cell.rate()
            rates[a, k] = (iv.rate, iv.low, iv.high)
            row.append(fmt_rate(iv, cell.trials))
        table.append(row)
    path = plot_rate_bars([s for _, s in scenarios],
                          [f"{k} game player{'s' if k != 1 else ''}" for k in range(max_players + 1)],
                          rates, rep.out / "fig3-success-rates.png",
                          title=f"Success rate per scenario and game players (NOD, {planner} planner)")
    rep.figure(path, "success rates", f"from study `{STUDY_SUCCESS}`")
    rep.add(*md_table(["scenario"] + [f"k = {k}" for k in range(max_players + 1)], table))
    rep.add("", "*k: game players per robot (k = N_r - 1 is every other robot, the paper's first study).*")
    sentences = []
    some = [c for c in cells if c.key[2] >= 1]
    none = [c for c in cells if c.key[2] == 0]
    if some:
        k, n = pooled(some)
        iv = wilson_interval(k, n)
        worst = min(some, key=lambda c: c.rate().rate)
        below = [c for c in some if c.rate().high < (PAPER_NEAR_ALL - NEAR_ALL_MARGIN) / 100]
        verdict = ("consistent with" if iv.high * 100 >= PAPER_NEAR_ALL - NEAR_ALL_MARGIN and not below
                   else "below")
        sentences.append(f"With at least one game player, {k} of {n} trials succeeded: {fmt_rate(iv)} % pooled "
                         f"(paper: close to 100 %), lowest cell {worst.key[1]} k = {worst.key[2]} at "
                         f"{fmt_rate(worst.rate(), worst.trials)}. Read against 'close to 100 %' taken as "
                         f"at least {PAPER_NEAR_ALL - NEAR_ALL_MARGIN:.0f} %, this is {verdict} the paper"
                         + (f"; {len(below)} cell(s) have their whole interval below that: "
                            + ", ".join(f"{c.key[1]} k = {c.key[2]}" for c in below) if below else "") + ".")
        full = [c for c in some if c.key[2] == c.key[0] - 1]
        reduced = [c for c in some if c.key[2] < c.key[0] - 1]
        if full and reduced:
            kf, nf = pooled(full)
            kr, nr = pooled(reduced)
            d = newcombe_difference(kr, nr, kf, nf)
            sentences.append(f"Game reduction (1 <= k < N_r - 1, {nr} trials) against all players (k = N_r - 1, "
                             f"{nf} trials): {fmt_rate(wilson_interval(kr, nr))} vs "
                             f"{fmt_rate(wilson_interval(kf, nf))} %, difference {100 * d.rate:+.1f} points "
                             f"[{100 * d.low:+.1f}, {100 * d.high:+.1f}] (Newcombe 95 %).")
    if none:
        k, n = pooled(none)
        iv = wilson_interval(k, n)
        sentences.append(f"Without game players, {k} of {n} trials succeeded: {fmt_rate(iv)} % (paper: 0 %). "
                         + ("Every one of them failed, as in the paper." if k == 0 else
                            "Unlike the paper, some succeeded; see the outcomes below."))
        failures = {o: pooled(none, o)[0] for o in OUTCOMES if o != "success"}
        sentences.append("Their outcomes: " + ", ".join(f"{o} {v}" for o, v in failures.items() if v) + ".")
    rep.read(sentences)


def section_strategies(rep: ReportDocument, title: str, study: str, scenario: str, column: str, paper: dict,
                       labels: dict, table: str, figure: str, intro: str) -> None:
    """A table of realised passing orders against the paper's (Tables I and II), with its figure."""
    rep.add(f"## {title}", "", intro)
    if not rep.has(study):
        rep.absent(study, "Run `nodnav reproduce` to add it.")
        return
    n_r = rep.store.records(study)[0].n_robots
    orders = passing_orders(n_r)
    rows = table_rows(rep.store, study, column, list(paper), n_r)
    header = ([labels["header"]] + [f"S{j + 1} {order_label(o)}" for j, o in enumerate(orders)]
              + ["trials", "no complete order"])
    lines: list[list] = []
    for freq in rows:
        lines.append([f"{labels[freq.label]} (paper)"] + [f"{v:.2f}" for v in paper[freq.label]] + ["", ""])
        sh = freq.share
        rate, low, high = np.asarray(sh.rate), np.asarray(sh.low), np.asarray(sh.high)  # one per strategy
        lines.append([f"{labels[freq.label]} (ours)"] + [
            f"{100 * rate[j]:.1f} [{100 * low[j]:.0f}, {100 * high[j]:.0f}]" if freq.realised else "-"
            for j in range(len(orders))] + [freq.trials, freq.incomplete])
    path = plot_strategy_frequencies(rows, [paper[f.label] for f in rows],
                                     [f"{labels['header']} = {labels[f.label]}" for f in rows],
                                     rep.out / figure, title=f"{scenario}: realised passing orders")
    rep.figure(path, title, f"from study `{study}`")
    rep.add(*md_table(header, lines))
    rep.add("", "*Ours: share of the realised passing orders (the order in which the robots entered the corridor), "
            "with its 95 % interval; trials that ended before every robot entered count under 'no complete order'.*")
    sentences = []
    for freq in rows:
        name = f"{labels['header']} = {labels[freq.label]}"
        if not freq.realised:
            sentences.append(f"{name}: no trial realised a complete order.")
            continue
        inside = paper_inside(freq, paper[freq.label])
        used = int(np.sum(freq.counts > 0))
        text = (f"{name}: {freq.realised} trials realised an order; {used} of {len(orders)} strategies occurred "
                f"(paper: {int(np.sum(np.asarray(paper[freq.label]) > 0))}); the paper's percentage lies inside our "
                f"interval for {inside} of {len(orders)} strategies")
        claimed = PAPER_CLAIMED_SETS.get((table, freq.label))
        if claimed:
            iv = freq.set_share(claimed)
            names = " or ".join(f"S{j}" for j in claimed)
            text += (f"; {names} (the paper's only choices) took {fmt_rate(iv)} % of ours (paper: 100 %), "
                     + ("consistent with the paper" if iv.high >= 0.999 else
                        "so other orders also occurred, unlike the paper"))
        sentences.append(text + ".")
    rep.read(sentences)


def section_fig2(rep: ReportDocument, heatmap_grid: int) -> None:
    """Fig. 2: the pure NOD's steady-state selection (recomputed) and the closed-loop grid (stored)."""
    rep.add("## Fig. 2: strategy selection of two robots over initial opinions", "",
            "Two robots, strategies S1 = (1,2) and S2 = (2,1), z_12(0) = z_22(0) = 0. (a) and (b): the steady-state "
            "limit of x_11 under the pure NOD, eqs. (1) and (3), for u = 1 and u = 10, integrated to convergence "
            f"on a {heatmap_grid} x {heatmap_grid} grid (recomputed, deterministic). The pure NOD predicts x_11 = 1/2 "
            "everywhere for u < 2 and, for u > 2, agreement on S1 when z_11(0) + z_21(0) > 0 and on S2 when it is "
            "negative.")
    sentences = []
    for u, tag in ((1.0, "a"), (10.0, "b")):
        result = steady_state_selection(u, z_grid(heatmap_grid))
        path = plot_heatmap(result, rep.out / f"fig2{tag}-nod-u{u:g}.png")
        rep.figure(path, f"Fig. 2{tag}", f"(recomputed from eqs. (1) and (3), u = {u:g})")
        x = result.x11
        z = result.z_values
        total = z[:, None] + z[None, :]
        if u < 2:
            sentences.append(f"Fig. 2{tag} (u = {u:g}): lim x_11 lies in [{x.min():.4f}, {x.max():.4f}]"
                             f"{'' if result.converged else ' (not converged: ' + result.reason + ')'}; "
                             "no strategy is preferred, as predicted.")
        else:
            pos, neg = total > 1e-12, total < -1e-12
            sentences.append(f"Fig. 2{tag} (u = {u:g}): lim x_11 > 0.99 on {int((x[pos] > 0.99).sum())} of "
                             f"{int(pos.sum())} cells with z_11(0) + z_21(0) > 0 and < 0.01 on "
                             f"{int((x[neg] < 0.01).sum())} of {int(neg.sum())} with it negative; on the anti-diagonal "
                             f"it is {np.diag(x[:, ::-1]).min():.3f}..{np.diag(x[:, ::-1]).max():.3f}"
                             f"{'' if result.converged else ' (not converged: ' + result.reason + ')'}.")
    rep.add("### Fig. 2c: the closed loop", "")
    if not rep.has(STUDY_FIG2C):
        rep.absent(STUDY_FIG2C, "Run `nodnav reproduce` to add it.")
        rep.read(sentences)
        return
    grid = closed_loop_grid(rep.store.records(STUDY_FIG2C, method="nod"))
    n = len(grid.z_values)
    per_cell = sorted(set(grid.trials.ravel().tolist()))
    rep.add(f"2-Robot Case-2 with u = {grid.u:g}, the initial opinions z_11(0), z_21(0) set on a {n} x {n} grid over "
            f"[{grid.z_values.min():g}, {grid.z_values.max():g}] and {'/'.join(map(str, per_cell))} trial(s) per "
            "cell (a grid and trial count sized to the time budget; the paper does not give its own). Each cell is "
            "the share of trials whose robots entered the corridor in the order S1 = (1,2); grey cells realised no "
            "order.")
    path = plot_closed_loop_grid(grid, rep.out / "fig2c-closed-loop.png")
    rep.figure(path, "Fig. 2c", f"from study `{STUDY_FIG2C}`")
    agree, decided = sign_rule_agreement(grid)
    sentences.append(f"Fig. 2c: {int(grid.trials.sum())} trials, {int(grid.realised.sum())} realised an order. In "
                     f"{agree} of {decided} cells off the anti-diagonal with a majority, the majority order is the one "
                     "the pure NOD selects (S1 when z_11(0) + z_21(0) > 0).")
    rep.read(sentences)
