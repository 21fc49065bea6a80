"""Mixed teams in stored results: trials grouped by who ran what, with rates and intervals.

A trial of a mixed team stores each robot's method and the contacts with people by cause
(:mod:`nodnav.sim.team_contacts`) in its summary. :func:`team_rows` groups stored trials by their
roles (which robots ran which method other than the trial's) and gives, per group:

- ``robots_ok``: every robot (not person) arrived and no robot caused a contact (the measure
  of docs/mixed-teams.md: robots arrive without contact they caused);
- ``success``: the simulator's outcome: every robot and person arrived, no robot caused a contact;
- ``contact_free``: success and no robot touched anyone at all, whoever caused it;
- contacts caused by robots and by people, the robots' makespan, and the mean delay of the robots
  that run the trial's method (the NOD robots among the others).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nodnav.experiments.statistics import Interval, mean_sd, wilson_interval
from nodnav.experiments.store import TrialRecord, canonical_json
from nodnav.experiments.study import SweepSpec
from nodnav.scenario.catalogue import PAPER_SCENARIOS
from nodnav.scenario.schema import scenario_from_dict
from nodnav.sim.team_contacts import free_times

STUDY_MIXED_TEAMS = "mixed-teams"
"""The ``mixed-teams`` part of ``nodnav reproduce``: robot 1 replaced in the paper's ten and ``mixed``."""
MIXED_TEAMS_ROLES = ((("1", "person"),), (("1", "person-yielding"),), (("1", "closest-first"),), (("1", "orca"),))
"""Robot 1 a person, a yielding person, a closest-first robot, an ORCA robot; the others run NOD."""
MIXED_TEAMS_TITLE = "beyond the paper: NOD robots with a person or a robot of another convention"
"""The part's title in the report's table of what was run."""


def mixed_teams_spec(trials: int) -> SweepSpec:
    """The mixed-teams study: the paper's ten with seeds ``1..trials`` and the ``mixed`` family's
    draws ``1..trials``, each with every role of :data:`MIXED_TEAMS_ROLES`."""
    return SweepSpec(STUDY_MIXED_TEAMS, PAPER_SCENARIOS, families=("mixed",), roles=MIXED_TEAMS_ROLES,
                     planners=("fast",), trials=trials)


def role_label(record: TrialRecord) -> str:
    """Who ran what besides the trial's method, e.g. ``robot 1: person`` or ``last robot: orca``;
    ``all METHOD`` when every robot ran the trial's method."""
    robots = record.config["scenario"]["robots"]
    n = len(robots)
    parts = []
    for i, r in enumerate(robots):
        if r.get("method") and r["method"] != record.method:
            where = "robot 1" if i == 0 else "last robot" if i == n - 1 else f"robot {i + 1}"
            parts.append(f"{where}: {r['method']}")
    return ", ".join(parts) if parts else f"all {record.method}"


def role_order(record: TrialRecord) -> tuple:
    """Sort key of :func:`role_label`: every robot's method first, then by the robots given
    another method (robot 1 first, the last robot after every numbered one)."""
    robots = record.config["scenario"]["robots"]
    n = len(robots)
    where = tuple(10**6 if i == n - 1 and i > 0 else i for i, r in enumerate(robots)
                  if r.get("method") and r["method"] != record.method)
    return (len(where), where, role_label(record))


@dataclass(frozen=True)
class TeamRow:
    """The figures of one group of trials (one role assignment)."""

    label: str
    trials: int
    robots_ok: Interval
    """Rate of trials in which every robot arrived and no robot caused a contact (Wilson 95 %)."""
    robots_ok_count: int
    success: Interval
    contact_free: Interval
    contacts_by_robots: int
    contacts_by_people: int
    trials_with_contact: int
    makespan: tuple[float, float, int]
    """Robots' makespan (s) over the trials in which every robot arrived: mean, sd, count."""
    delay: tuple[float, float, int]
    """Mean delay of the robots that run the trial's method (s, arrival minus time alone; the NOD
    robots in a NOD trial) over those trials: mean, sd, count."""


def robot_delays(record: TrialRecord, cache: dict) -> list[float | None]:
    """Each robot's delay (s) in a stored trial: its own ``delay_s`` (mixed teams), else its time
    to goal minus :func:`~nodnav.sim.team_contacts.free_times` of the stored scenario."""
    stored = record.summary.get("delay_s")
    if stored is not None:
        return stored
    key = canonical_json(record.config["scenario"])
    if key not in cache:
        cache[key] = free_times(scenario_from_dict(record.config["scenario"], record.scenario))
    times = record.summary.get("time_to_goal_s") or []
    return [None if t is None or not np.isfinite(f) else float(t - f) for t, f in zip(times, cache[key])]


def team_rows(records: list[TrialRecord], by_scenario: bool = False) -> list[TeamRow]:
    """One :class:`TeamRow` per role assignment among ``records`` (errors left out), in the order of
    :func:`role_order` (not the store's, which ties break by trial key); per scenario and role
    assignment with ``by_scenario`` (labelled ``SCENARIO, ROLES``)."""
    groups: dict[str, list[TrialRecord]] = {}
    for r in sorted(records, key=role_order):
        if r.outcome != "error":
            label = f"{r.scenario}, {role_label(r)}" if by_scenario else role_label(r)
            groups.setdefault(label, []).append(r)
    rows: list[TeamRow] = []
    alone: dict[str, np.ndarray] = {}  # times alone per stored scenario
    for label, group in (sorted(groups.items()) if by_scenario else groups.items()):
        n = len(group)
        ok = success = free = by_robots = by_people = touched = 0
        makespans, delays = [], []
        for r in group:
            s = r.summary
            caused = int(s.get("contacts_caused_by_robots") or 0)
            arrived = bool(s.get("robots_arrived", r.outcome == "success"))
            ok += arrived and caused == 0 and r.outcome != "collision"
            success += r.outcome == "success"
            free += bool(s.get("success_contact_free", r.outcome == "success"))
            by_robots += caused
            by_people += int(s.get("contacts_caused_by_people") or 0)
            touched += int(s.get("contacts") or 0) > 0
            if arrived:
                makespans.append(s.get("robots_makespan_s", s.get("makespan_s")))
                plain = [k for k, robot in enumerate(r.config["scenario"]["robots"])
                         if robot.get("method") in (None, r.method)]
                own = [d for k, d in enumerate(robot_delays(r, alone)) if k in plain]
                if own and all(d is not None for d in own):
                    delays.append(float(np.mean([float(d) for d in own if d is not None])))
        rows.append(TeamRow(label=label, trials=n, robots_ok=wilson_interval(ok, n), robots_ok_count=ok,
                            success=wilson_interval(success, n), contact_free=wilson_interval(free, n),
                            contacts_by_robots=by_robots, contacts_by_people=by_people, trials_with_contact=touched,
                            makespan=mean_sd(makespans), delay=mean_sd(delays)))
    return rows
