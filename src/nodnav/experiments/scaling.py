"""The scaling part of ``nodnav reproduce``: the crowd built-ins (5 to 8 robots) at k = 1, 2, 3.

The paper stops at 4 robots; this part runs every built-in scenario beyond the paper's ten
(:func:`~nodnav.scenario.catalogue.crowd_scenarios`: crowds at the doors, head-on, one-sided and
mixed) with 1, 2 and 3 game players per robot, NOD with the fast planner, as an ordinary
resumable sweep (study :data:`STUDY_SCALING`) into the same results database as the paper's
parts. All players is left out: above 6 robots it is refused
(:data:`~nodnav.scenario.limits.MAX_STRATEGIES`). The report's section on it is
:mod:`nodnav.reporting.scaling`.
"""

from __future__ import annotations

from nodnav.experiments.study import SweepSpec
from nodnav.scenario.catalogue import crowd_scenarios

STUDY_SCALING = "beyond-scaling"
"""The crowd built-ins x 1, 2, 3 game players, NOD with the fast planner."""
SCALING_PLAYERS = (1, 2, 3)
"""Game players per robot of the scaling part."""
SCALING_TITLE = "beyond the paper: 5-8 robots at k = 1, 2, 3"
"""The part's title in the report's table of what was run."""


def scaling_spec(trials: int) -> SweepSpec:
    """The scaling study with seeds ``1..trials`` per cell."""
    return SweepSpec(STUDY_SCALING, crowd_scenarios(), players=SCALING_PLAYERS, planners=("fast",), trials=trials)
