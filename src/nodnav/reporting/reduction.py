"""The report's section on the game-reduction variants (:mod:`nodnav.experiments.variants`)."""

from __future__ import annotations

from nodnav.experiments.analysis import rate_cells
from nodnav.experiments.statistics import fmt_rate, newcombe_difference, wilson_interval
from nodnav.experiments.variants import STUDY_REDUCTION, VARIANTS, reduction_rows
from nodnav.reporting.document import ReportDocument
from nodnav.reporting.markdown import md_table


def section_reduction(rep: ReportDocument) -> None:
    """The report section: success per scenario and k for every variant, side by side."""
    rep.add("## Game reduction: variants side by side", "",
            "Every built-in scenario of three or four robots with every number of game players "
            "1 <= k < N_r - 1, zero initial opinions, no bias, NOD with the fast planner, run as each "
            "of these variants (`opinion.conflict`, `opinion.nonplayers` in the scenario file):", "")
    rep.add(*(f"- `{v.name}`: {v.description}" for v in VARIANTS), "")
    if not rep.has(STUDY_REDUCTION):
        rep.absent(STUDY_REDUCTION, "Run `nodnav reproduce` (part `reduction`) to add it.")
        return
    header, rows, totals = reduction_rows(rate_cells(rep.store, STUDY_REDUCTION, by=("scenario", "players")))
    rep.add(*md_table(header, rows))
    sentences = []
    if "paper" in totals:
        s0, n0 = totals["paper"]
        for v in VARIANTS[1:]:
            if v.name in totals:
                s1, n1 = totals[v.name]
                d = newcombe_difference(s1, n1, s0, n0)
                sentences.append(f"`{v.name}` against the paper's rule: {fmt_rate(wilson_interval(s1, n1))} vs "
                                 f"{fmt_rate(wilson_interval(s0, n0))} %, difference {100 * d.rate:+.1f} points "
                                 f"[{100 * d.low:+.1f}, {100 * d.high:+.1f}] (Newcombe 95 %).")
    if totals:
        best = max(totals, key=lambda name: totals[name][0] / totals[name][1])
        sentences.append(f"Highest pooled success: `{best}`.")
    rep.read(sentences)
