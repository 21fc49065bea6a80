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
``QP solve``              ``SolverEffort.solve``, ``SolverEffort.certificate`` and
                          ``SolverEffort.relaxation`` (DAQP, the certificate LPs and the
                          evasive fallback's least-relaxation LPs)
``simulation``            the simulator's ``_judge`` (contact checks at the sub-steps, arrival,
                          progress) and ``_observe`` (sensing with its noise)
``bookkeeping: act``      the method's ``act`` outside the controllers (predictions, reaction
                          margins, surprise, plan execution, building the control requests)
``bookkeeping: loop``     the rest: the loop, the views, histories, corridor entries, building
                          the trial and its metrics
========================  ==================================================================

Each interval is read on two clocks: wall time, and this process's processor time
(``time.process_time``), which leaves out the time the trial waited while other programs held
the processor and so is the steadier figure on a shared machine. Measuring costs two clock
readings per switch; :func:`measure_stages` reports the
trial's wall time with the wrappers in place, and the benchmark compares it with the same trial
unmeasured (:mod:`nodnav.bench.closed_loop`).
"""

from __future__ import annotations

import functools
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Iterator

from nodnav.control.qp import SolverEffort
from nodnav.scenario.schema import Scenario
from nodnav.sim.simulator import Simulation

#: The stages, in the order they are reported; the last one takes whatever no other one claims.
#: Bookkeeping is reported in two parts: the method's ``act`` outside its controllers, and the rest.
STAGES = ("decision", "planning", "control set-up", "QP solve", "simulation", "bookkeeping: act",
          "bookkeeping: loop")
ROOT = STAGES[-1]


class StageClock:
    """Exclusive wall time per stage: an interval is charged to the innermost stage running."""

    def __init__(self) -> None:
        self.totals = dict.fromkeys(STAGES, 0.0)
        """Wall time per stage (s)."""
        self.cpu = dict.fromkeys(STAGES, 0.0)
        """Processor time of this process per stage (s): what the stage costs, without the time
        it waited for a processor that other programs held."""
        self.calls = dict.fromkeys(STAGES, 0)
        self._stack = [ROOT]
        self._last = self._began = time.perf_counter()
        self._last_cpu = self._began_cpu = time.process_time()

    def start(self) -> None:
        """Begin the trial's time now (charged to the root stage until a wrapped call begins)."""
        self._last = self._began = time.perf_counter()
        self._last_cpu = self._began_cpu = time.process_time()

    def elapsed(self) -> tuple[float, float]:
        """Wall and processor time (s) from :meth:`start` to the last switch (:meth:`stop`): the
        span the stages partition, so their sums equal it whatever else the machine runs."""
        return self._last - self._began, self._last_cpu - self._began_cpu

    def stop(self) -> None:
        """Charge the time since the last switch to the stage running now."""
        self._switch()

    def _switch(self) -> None:
        now, cpu = time.perf_counter(), time.process_time()
        self.totals[self._stack[-1]] += now - self._last
        self.cpu[self._stack[-1]] += cpu - self._last_cpu
        self._last, self._last_cpu = now, cpu

    def wrap(self, stage: str, fn: Callable) -> Callable:
        """``fn`` with its time (less that of stages it calls) charged to ``stage``."""
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            self._switch()
            self._stack.append(stage)
            self.calls[stage] += 1
            try:
                return fn(*args, **kwargs)
            finally:
                self._switch()
                self._stack.pop()
        return timed


def _set(obj, name: str, stage: str, clock: StageClock) -> None:
    """Wrap the bound method ``obj.name`` on that object only."""
    object.__setattr__(obj, name, clock.wrap(stage, getattr(obj, name)))


def instrument(sim: Simulation, clock: StageClock) -> None:
    """Set the clock's wrappers on one trial's objects (its method or team, planner, controllers)."""
    members = list(getattr(sim.method, "members", {}).values()) or [sim.method]
    _set(sim.method, "decide", "decision", clock)
    _set(sim.method, "act", "bookkeeping: act", clock)
    planners: list[object] = []
    for m in members:
        if m is not sim.method:
            _set(m, "decide", "decision", clock)
            _set(m, "act", "bookkeeping: act", clock)
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
    saved = {name: SolverEffort.__dict__[name] for name in ("solve", "certificate", "relaxation")}
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
    cpu_seconds: dict[str, float]
    """Exclusive processor time per stage (s); on a shared machine the steadier figure."""
    calls: dict[str, int]
    """Calls of each stage's wrapped entry points."""
    wall_time: float
    """The trial's wall time with the clock in place (s)."""
    cpu_time: float
    """The trial's processor time with the clock in place (s)."""
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
        wall, cpu = clock.elapsed()
    return StageTimes(seconds=dict(clock.totals), cpu_seconds=dict(clock.cpu), calls=dict(clock.calls),
                      wall_time=wall, cpu_time=cpu,
                      sim_time=result.sim_time, outcome=result.outcome)
