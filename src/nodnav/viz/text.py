"""Titles that fit their figure: long text (a scenario's description, a failure reason) is wrapped
to the width its axes or figure has, instead of running off the figure's edges."""

from __future__ import annotations

import textwrap

from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.text import Text

#: Width of an average character of matplotlib's default font (DejaVu Sans), in ems; a little
#: generous (mixed text averages about 0.55), so that a wrapped line stays inside its width.
CHAR_EM = 0.6
#: Most lines a title is given; a longer text ends in "..." (a figure has no room for a page).
MAX_LINES = 6


def wrap_text(text: str, width_in: float, fontsize: float, max_lines: int = MAX_LINES) -> str:
    """``text`` with every line wrapped to ``width_in`` inches at ``fontsize`` points, in at most
    ``max_lines`` lines (the last cut with "..." when the text needs more)."""
    chars = max(12, int(width_in * 72.0 / (CHAR_EM * fontsize)))
    lines: list[str] = []
    for paragraph in text.split("\n"):
        lines += textwrap.wrap(paragraph, chars, break_on_hyphens=False) or [""]
    if len(lines) > max_lines:
        lines = lines[:max_lines]
        lines[-1] = lines[-1][: max(0, chars - 3)].rstrip() + "..."
    return "\n".join(lines)


def _axes_width(ax: Axes) -> float:
    fig = ax.get_figure()
    assert isinstance(fig, Figure)  # axes drawn by nodnav live in a Figure, not a SubFigure
    return ax.get_position().width * fig.get_figwidth()


def set_title(ax: Axes, text: str, fontsize: float, **kwargs) -> Text:
    """``ax.set_title`` with ``text`` wrapped to the axes' width (a title may reach a little into
    the margins beside its axes, as far as 10 % of that width)."""
    return ax.set_title(wrap_text(text, 1.1 * _axes_width(ax), fontsize), fontsize=fontsize, **kwargs)


def set_suptitle(fig: Figure, text: str, fontsize: float, **kwargs) -> Text:
    """``fig.suptitle`` with ``text`` wrapped to 95 % of the figure's width."""
    return fig.suptitle(wrap_text(text, 0.95 * fig.get_figwidth(), fontsize), fontsize=fontsize, **kwargs)
