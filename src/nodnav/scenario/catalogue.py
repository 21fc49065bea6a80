"""Which built-in scenarios are the paper's and which go beyond it.

The paper evaluates 2, 3 and 4 robots; its ten scenarios are what ``nodnav reproduce`` runs for
the paper's parts, what ``nodnav bench planners`` plans every order of, and what ``sweep
--scenario paper`` names. The crowd scenarios (5 to 8 robots queueing at the doors, issue 12)
are built-ins too, for ``nodnav run``, the gallery and the scaling part of ``nodnav reproduce``;
with 7 and 8 robots they refuse all players (:data:`~nodnav.scenario.limits.MAX_STRATEGIES`), so
they are kept out of studies that set every robot a game player.
"""

from __future__ import annotations

from nodnav.scenario.files import builtin_names
from nodnav.scenario.loading import load_scenario

#: The paper's scenarios (2-Robot Case-1 .. 4-Robot Case-4).
PAPER_SCENARIOS = ("2r-case1", "2r-case2", "3r-case1", "3r-case2", "3r-case3", "3r-case4",
                   "4r-case1", "4r-case2", "4r-case3", "4r-case4")


def crowd_scenarios() -> tuple[str, ...]:
    """The built-in scenarios beyond the paper's, by robot count then name."""
    names = [n for n in builtin_names() if n not in PAPER_SCENARIOS]
    return tuple(sorted(names, key=lambda n: (load_scenario(n).n_robots, n)))
