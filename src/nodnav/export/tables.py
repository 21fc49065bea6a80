"""A trial as a table for pandas: CSV and Parquet files, one row per robot and control step.

The columns are :meth:`~nodnav.sim.history.History.to_dataframe`'s, and, when the trial replays
(:mod:`nodnav.export.plans`), ``plan_x`` and ``plan_y``: where the robot's current plan (its latest
decision's) puts it at that step (m). Floats are written so that they read back exactly
(CSV: ``pandas.read_csv(path)`` from pandas 3; with pandas 2 add ``float_precision="round_trip"``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from nodnav.export.plans import Plans
from nodnav.sim.history import History


def trial_frame(history: History, plans: Plans | None = None):
    """The history's data frame, with the plan columns when ``plans`` replayed."""
    frame = history.to_dataframe()
    if plans is None or not plans.success:
        return frame
    planned = np.full((len(frame), 2), np.nan)
    robots, decided, times = frame["robot"].to_numpy() - 1, frame["decision_time"].to_numpy(), frame["time"].to_numpy()
    for plan in plans.plans:
        rows = np.flatnonzero((robots == plan.robot) & (decided == plan.decision_time))
        if len(rows) and len(plan.times):  # held at its end, as the controller holds a finished plan
            planned[rows, 0] = np.interp(times[rows], plan.times, plan.positions[:, 0])
            planned[rows, 1] = np.interp(times[rows], plan.times, plan.positions[:, 1])
    at = frame.columns.get_loc("decision_time")
    frame.insert(at, "plan_y", planned[:, 1])
    frame.insert(at, "plan_x", planned[:, 0])
    return frame


def write_csv(frame, out: Path) -> Path:
    """``frame`` as CSV (every float as its shortest exact text)."""
    frame.to_csv(out, index=False, float_format=None)
    return out


def write_parquet(frame, out: Path) -> Path:
    """``frame`` as Parquet (pyarrow)."""
    frame.to_parquet(out, index=False, engine="pyarrow")
    return out
