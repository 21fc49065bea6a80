"""Where a trial's time goes: the closed loop's wall time split into stages, measured from outside.

A :class:`StageClock` wraps the entry points of each stage of one trial with
``time.perf_counter`` readings and charges every interval to the stage innermost at the time, so
each instant of the trial belongs to exactly one stage and the stages add up to the trial's wall
time. Nothing in the closed loop is edited: the wrappers are set on the trial's own objects
(its method, planner, controllers and simulation) and, for the QP solver, on
:class:`~nodnav.control.qp.SolverEffort` for the duration of the trial only.

The mapping of functions to stages (the innermost wins):

========================  ==================================================================
stage                     entry points
========================  ==================================================================
``decision``              the method's ``decide`` (opinions, game players, eq. (4), selection)
``planning``              the planner's ``plan`` (every planner call, inside decisions or not)
``control set-up``        each robot controller's ``control`` (building the MPC's QP data,
                          braking fallbacks, checks of the solution)
``QP solve``              ``SolverEffort.solve`` and ``SolverEffort.certificate`` (DAQP and the
                          certificate LPs)
``simulation``            the simulator's ``_judge`` (contact checks at the sub-steps, arrival,
                          progress) and ``_observe`` (sensing with its noise)
``bookkeeping``           the rest: the loop, the views, histories, corridor entries, the
                          method's ``act`` outside the controllers (predictions, reaction
                          margins, surprise, plan execution), building the trial and its metrics
========================  ==================================================================

Measuring costs a few perf_counter calls per wrapped call; :func:`measure_stages` reports the
trial's wall time with the wrappers in place, and the benchmark compares it with the same trial
unmeasured (:mod:`nodnav.bench.closed_loop`).
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Iterator

from nodnav.control.qp import SolverEffort
from nodnav.scenario.schema import Scenario
from nodnav.sim.simulator import Simulation

#: The stages, in the order they are reported; the last one takes whatever no other one claims.
STAGES = ("decision", "planning", "control set-up", "QP solve", "simulation", "bookkeeping")
ROOT = STAGES[-1]


class StageClock:
    """Exclusive wall time per stage: an interval is charged to the innermost stage running."""

    def __init__(self) -> None:
        self.totals = dict.fromkeys(STAGES, 0.0)
        self.calls = dict.fromkeys(STAGES, 0)
        self._stack = [ROOT]
        self._last = time.perf_counter()

    def start(self) -> None:
        """Begin the trial's time now (charged to the root stage until a wrapped call begins)."""
        self._last = time.perf_counter()

    def stop(self) -> None:
        """Charge the time since the last switch to the stage running now."""
        self._switch()

    def _switch(self) -> None:
        now = time.perf_counter()
        self.totals[self._stack[-1]] += now - self._last
        self._last = now

    def wrap(self, stage: str, fn: Callable) -> Callable:
        """``fn`` with its time (less that of stages it calls) charged to ``stage``."""
        def timed(*args, **kwargs):
            self._switch()
            self._stack.append(stage)
            self.calls[stage] += 1
            try:
                return fn(*args, **kwargs)
            finally:
                self._switch()
                self._stack.pop()
        timed.__wrapped__ = fn  # type: ignore[attr-defined]
        return timed


def _set(obj, name: str, stage: str, clock: StageClock) -> None:
    """Wrap the bound method ``obj.name`` on that object only."""
    object.__setattr__(obj, name, clock.wrap(stage, getattr(obj, name)))


def instrument(sim: Simulation, clock: StageClock) -> None:
    """Set the clock's wrappers on one trial's objects (its method or team, planner, controllers)."""
    members = list(getattr(sim.method, "members", {}).values()) or [sim.method]
    _set(sim.method, "decide", "decision", clock)
    planners = []
    for m in members:
        if m is not sim.method:
            _set(m, "decide", "decision", clock)
        plans = getattr(m, "plans", None)
        planner = getattr(plans, "planner", None) or getattr(m, "planner", None)
        if planner is not None and all(planner is not p for p in planners):
            planners.append(planner)
            _set(planner, "plan", "planning", clock)
        for c in getattr(m, "controllers", ()):
            _set(c, "control", "control set-up", clock)
    _set(sim, "_judge", "simulation", clock)
    _set(sim, "_observe", "simulation", clock)


@contextmanager
def qp_timed(clock: StageClock) -> Iterator[None]:
    """``SolverEffort``'s solver calls charged to ``QP solve`` while inside (restored after)."""
    saved = {name: SolverEffort.__dict__[name] for name in ("solve", "certificate")}
    try:
        for name, fn in saved.items():
            setattr(SolverEffort, name, clock.wrap("QP solve", fn))
        yield
    finally:
        for name, fn in saved.items():
            setattr(SolverEffort, name, fn)


@dataclass(frozen=True)
class StageTimes:
    """One trial's wall time split into :data:`STAGES`."""

    seconds: dict[str, float]
    """Exclusive wall time per stage (s)."""
    calls: dict[str, int]
    """Calls of each stage's wrapped entry points."""
    wall_time: float
    """The trial's wall time with the clock in place (s)."""
    sim_time: float
    """Simulated time (s)."""
    outcome: str
    """The trial's outcome."""


def measure_stages(scenario: Scenario, seed: int, method: str = "nod") -> StageTimes:
    """Run one trial as :func:`~nodnav.sim.simulator.run_trial` does, with every stage timed."""
    clock = StageClock()
    with qp_timed(clock):
        start = time.perf_counter()
        clock.start()
        sim = Simulation(scenario, method, seed)
        instrument(sim, clock)
        while not sim.step():
            pass
        result = sim.result(time.perf_counter() - start)
        clock.stop()
        wall = time.perf_counter() - start
    return StageTimes(seconds=dict(clock.totals), calls=dict(clock.calls), wall_time=wall,
                      sim_time=result.sim_time, outcome=result.outcome)
