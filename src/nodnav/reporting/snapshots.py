"""The report's snapshot figures (the paper's Figs. 4 and 5): stored trials re-run from their seed."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from nodnav.experiments.paper import SNAPSHOTS, STUDY_SUCCESS, Snapshot
from nodnav.reporting.document import ReportDocument
from nodnav.scenario.schema import scenario_from_dict
from nodnav.sim.simulator import run_trial
from nodnav.viz.trial import save_snapshots

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SnapshotResult:
    """One snapshot figure: which stored trial was re-run and whether it came out the same."""

    scenario: str
    """Scenario name."""
    players: int
    """Game players per robot."""
    success: bool
    """Whether a figure was written."""
    reason: str
    """Why not, or what was re-run."""
    path: Path | str = ""
    """The figure."""
    seed: int = 0
    """Seed of the re-run trial."""
    reproduced: bool = False
    """Whether the re-run gave the stored outcome and simulated time."""


def section_snapshots(rep: ReportDocument, rerun: bool) -> list[SnapshotResult]:
    """The snapshot figures: each re-runs a stored trial and says whether it came out the same."""
    rep.add("## Snapshots (Figs. 4 and 5)", "",
            "A successful stored trial (the lowest such seed; the lowest seed if none succeeded) is re-run from "
            "its stored configuration and seed; "
            "trials are reproducible from their seed, and the report checks that the re-run ends with the stored "
            "outcome at the stored time. Top row: robots, trails and game players (arrows to each robot's players); "
            "bottom: each robot's chosen passing order at every decision and its probability.")
    results = []
    for snap in SNAPSHOTS:
        results.append(snap_result := rerun_snapshot(rep, snap, rerun))
        if snap_result.success:
            rep.add("", f"**{snap['paper']}** (seed {snap_result.seed}): {snap_result.reason}")
            rep.figure(Path(snap_result.path), snap["paper"],
                       f"by re-running seed {snap_result.seed} of study `{STUDY_SUCCESS}`")
        else:
            rep.add("", f"**{snap['paper']}**: {snap_result.reason}", "")
    return results


def rerun_snapshot(rep: ReportDocument, snap: Snapshot, rerun: bool) -> SnapshotResult:
    """Re-run the stored trial a snapshot figure shows (``rerun`` false: only say which) and draw it."""

    stored = rep.store.records(STUDY_SUCCESS, scenario=snap["scenario"], players=snap["players"], method="nod")
    stored = [r for r in stored if r.planner == "fast"] or stored
    if not stored:
        return SnapshotResult(snap["scenario"], snap["players"], False,
                              f"no trial of {snap['scenario']} with {snap['players']} game player(s) is stored.")
    successes = [r for r in stored if r.success]
    # Without a stored success, the lowest seed shows how the method fails here instead.
    record = successes[0] if successes else stored[0]
    caveat = "" if successes else (f"none of the {len(stored)} stored trials succeeded, so this one shows how they "
                                   "fail; ")
    if not rerun:
        return SnapshotResult(snap["scenario"], snap["players"], False,
                              f"{caveat}seed {record.seed} would be re-run; re-runs were switched off for this report.",
                              seed=record.seed)
    scenario = scenario_from_dict(record.config["scenario"])
    result = run_trial(scenario, record.method, record.seed)
    stored_time = record.summary.get("sim_time_s")
    same = result.outcome == record.outcome and stored_time is not None and abs(result.sim_time - stored_time) < 1e-6
    if not same:
        log.warning("%s seed %d re-ran to %s at t = %.1f s, stored: %s at t = %s s", record.scenario, record.seed,
                    result.outcome, result.sim_time, record.outcome, stored_time)
    path = save_snapshots(result.history, rep.out / snap["figure"], count=snap["count"])
    order = ",".join(str(k + 1) for k in result.entry_order)
    reason = (f"{caveat}re-run: {result.outcome} at t = {result.sim_time:.1f} s, corridor entry order ({order}); "
              + ("identical to the stored trial." if same else
                 f"DIFFERS from the stored trial ({record.outcome} at t = {stored_time} s): the trial is not "
                 "reproducible from its seed with this version."))
    return SnapshotResult(snap["scenario"], snap["players"], True, reason, path, record.seed, same)
