"""The paper's evaluation as studies: their names, what the paper reports, and its snapshot trials.

:mod:`nodnav.reporting.reproduce` runs these studies into one results database and
:mod:`nodnav.reporting.report` reads them back; both name them with the constants here.
"""

from __future__ import annotations

from typing import TypedDict

STUDY_SUCCESS = "paper-success-rates"
"""Every built-in scenario x every game-player count, NOD with the fast planner (Fig. 3)."""
STUDY_TABLE1 = "paper-table1"
"""3-Robot Case-2 with zero and distance-based initial opinions (Table I)."""
STUDY_TABLE2 = "paper-table2"
"""3-Robot Case-3 without bias and with b = 150 on S3 and S5 (Table II)."""
STUDY_FIG2C = "paper-fig2c"
"""2-Robot Case-2, u = 10, over a grid of given z_11(0), z_21(0) (Fig. 2c)."""
STUDY_METHODS = "methods"
"""Every navigation method on every built-in scenario with its own settings."""
STUDY_PLANNERS = "planners"
"""The success-rate study with every planner compared."""
META_STUDY = "reproduce"
"""Not a study of trials: what ``nodnav reproduce`` asked for and did, stored in the studies table."""

#: Table I of the paper, percent per strategy S1..S6, by initial opinions.
PAPER_TABLE1 = {"zero": (10.0, 21.67, 10.00, 18.33, 6.67, 33.33), "distance": (0.0, 0.0, 40.0, 60.0, 0.0, 0.0)}
#: Table II of the paper, percent per strategy S1..S6, by bias label.
PAPER_TABLE2 = {"": (6.67, 41.67, 8.33, 23.33, 1.67, 18.33), "S3=150,S5=150": (0.0, 0.0, 53.33, 0.0, 46.67, 0.0)}
#: The strategies each paper row's claim is about (1-based): robot 2 first (Table I, eq. (11)),
#: robot 1 second (Table II, bias).
PAPER_CLAIMED_SETS = {("table1", "distance"): (3, 4), ("table2", "S3=150,S5=150"): (3, 5)}
#: The paper's success rates (Fig. 3 and its text): 0 % without game players, "close to 100 %" with any.
PAPER_NEAR_ALL = 100.0
#: How close to 100 % "close to" is taken to be when reading our numbers against the paper.
NEAR_ALL_MARGIN = 10.0
#: A planner difference inside +-this many percentage points counts as "barely matters".
PLANNER_EQUIVALENCE = 10.0



class Snapshot(TypedDict):
    """A snapshot figure of the paper: the stored trials it shows and where it goes."""

    scenario: str
    """Built-in scenario."""
    players: int
    """Game players per robot."""
    count: int
    """Instants shown."""
    figure: str
    """File name of the figure."""
    paper: str
    """The paper's figure and caption."""


#: The paper's snapshot figures (Figs. 4 and 5).
SNAPSHOTS: tuple[Snapshot, ...] = (
    {"scenario": "3r-case4", "players": 2, "count": 4, "figure": "fig4-3r-case4-snapshots.png",
     "paper": "Fig. 4: 3-Robot Case-4, every robot plays with all others"},
    {"scenario": "4r-case4", "players": 1, "count": 5, "figure": "fig5-4r-case4-snapshots.png",
     "paper": "Fig. 5: 4-Robot Case-4, one game player per robot"},
)
