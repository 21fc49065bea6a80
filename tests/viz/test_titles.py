"""Long titles are wrapped to their figure: every line of a title lies inside the figure once drawn."""

import matplotlib

matplotlib.use("Agg")

from nodnav.api import build_scenario  # noqa: E402
from nodnav.viz.scenario import new_figure, scenario_figure  # noqa: E402
from nodnav.viz.text import MAX_LINES, set_suptitle, wrap_text  # noqa: E402

LONG = ("Two robots head-on in the paper's world, written by a user who explains at length what the scenario is "
        "for, where each robot starts and goes, and why the corridor is as wide as it is, in one long line of "
        "text that no figure of seven inches can hold on one line at eight points")


def _inside(fig, text) -> bool:
    fig.canvas.draw()
    box = text.get_window_extent(fig.canvas.get_renderer())
    return 0 <= box.x0 and box.x1 <= fig.bbox.width and 0 <= box.y0 and box.y1 <= fig.bbox.height


def test_wrap_keeps_every_word_within_the_width():
    wrapped = wrap_text(LONG, 7.0, 8)
    chars = int(7.0 * 72 / (0.6 * 8))  # 105 characters of 0.6 em at 8 pt in 7 inches
    lines = wrapped.split("\n")
    assert len(lines) == 3 and all(len(line) <= chars for line in lines)
    assert " ".join(lines) == LONG
    assert wrap_text("short\nsecond line", 7.0, 8) == "short\nsecond line"


def test_wrap_cuts_what_no_figure_can_hold():
    lines = wrap_text(LONG * 5, 3.0, 10).split("\n")
    assert len(lines) == MAX_LINES and lines[-1].endswith("...")


def test_a_long_scenario_description_stays_inside_the_figure():
    scenario = build_scenario({"name": "long", "description": LONG,
                               "robots": [{"origin": [-5, 0.5], "destination": [5, -0.5]},
                                          {"origin": [5, 0.5], "destination": [-5, -0.5]}]})
    fig = scenario_figure(scenario)  # as nodnav show draws it
    ax = fig.axes[0]
    assert _inside(fig, ax.title)
    assert ax.title.get_text().count("\n") >= 2  # the name, then the description on two lines or more
    ax.set_title("long\n" + LONG, fontsize=8)  # unwrapped, the same text runs off both edges
    assert not _inside(fig, ax.title)


def test_a_long_suptitle_stays_inside_the_figure():
    fig = new_figure(6.0, 3.0)
    fig.add_subplot(1, 1, 1)
    title = set_suptitle(fig, LONG, 10)
    assert _inside(fig, title)
