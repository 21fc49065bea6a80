"""Failure classes: what kind of failure a trial ended in, from its outcome and a few facts about it.

The simulator's outcome says *that* a trial failed (collision, deadlock, timeout); the class says
*which way*, so that a study can tell a jam of robots that agree on the order from a disagreement
or from robots standing still because no plan could be found.

========================== ==========================================================================
class                      the trial ended ...
========================== ==========================================================================
``success``                with every robot at its destination and no contact
``collision-robot-robot``  in a contact between two robots (also when a wall was touched at the same step)
``collision-wall``         in a contact between a robot and a wall
``collision-robot-person`` in a contact a robot caused with a person (:mod:`nodnav.sim.team_contacts`)
``plan-failure``           in a deadlock or at the time limit while plans were failing: at the last
                           decision at least one robot's selected plan had failed
``jam``                    in a deadlock although the robots agreed on the order still open (consensus)
``disagreement``           in a deadlock without agreement on the order still open
``timeout``                at the time limit, still making progress, plans not failing
========================== ==========================================================================

Plan failures come first among deadlocks and timeouts because a robot without a plan holds its
position whatever the others decide: agreement cannot help it.
"""

from __future__ import annotations

OUTCOMES = ("success", "collision", "deadlock", "timeout")
"""How a trial can end, as the simulator judges it."""

FAILURE_CLASSES = {
    "success": "every robot arrived, no contact",
    "collision-robot-robot": "two robots touched",
    "collision-wall": "a robot touched a wall",
    "collision-robot-person": "a robot moved into a person",
    "plan-failure": "deadlock or timeout while plans were failing at the last decision",
    "jam": "deadlock although the robots agreed on the open order",
    "disagreement": "deadlock without agreement on the open order",
    "timeout": "time limit reached while still progressing",
}
"""Every failure class and what it means, in report order."""

COLLISION_KINDS = ("robot-robot", "wall", "robot-person")
"""What a collision was between (``robot-robot`` also when a wall was touched at the same step)."""


def collision_kind(pair_contacts: int, wall_contacts: int) -> str:
    """``robot-robot``, ``wall``, or ``""`` when there was no contact."""
    return "robot-robot" if pair_contacts else "wall" if wall_contacts else ""


def classify(outcome: str, collision: str, consensus: bool, plans_failing_at_end: bool) -> str:
    """The failure class of a trial (see the module docstring); ``error`` passes through unchanged."""
    if outcome == "success":
        return "success"
    if outcome == "collision":
        if collision == "robot-person":
            return "collision-robot-person"
        return "collision-wall" if collision == "wall" else "collision-robot-robot"
    if outcome in ("deadlock", "timeout") and plans_failing_at_end:
        return "plan-failure"
    if outcome == "deadlock":
        return "jam" if consensus else "disagreement"
    if outcome == "timeout":
        return "timeout"
    return outcome


def plans_failing_at_end(events: list[dict], decision_times: list[float]) -> bool:
    """Whether some robot's selected plan failed at the last decision (``kind: plan`` events at that time)."""
    if not decision_times:
        return False
    last = round(decision_times[-1], 6)
    return any(e.get("kind") == "plan" and e.get("t") == last for e in events)


def failure_class(result) -> str:
    """The class of a :class:`~nodnav.sim.trial_result.TrialResult`."""
    h = result.history
    return classify(result.outcome, result.collision_kind, result.consensus,
                    plans_failing_at_end(h.events, h.decision_times))
