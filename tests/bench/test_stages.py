"""The stage breakdown of a trial's time: it partitions the wall time and moves where the work moves."""

import numpy as np

from nodnav.bench.stages import STAGES, StageClock, measure_stages
from nodnav.control.qp import SolverEffort
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial


def test_clock_charges_nested_calls_to_the_innermost_stage(monkeypatch):
    """Hand-made nesting on a clock that advances only when the work says so (0.02 s of the outer
    stage's own, 0.03 s of the inner one's): the outer stage keeps only its own time, whatever
    the machine's load."""
    import types

    from nodnav.bench import stages

    now = [100.0]

    def work(seconds: float) -> None:
        now[0] += seconds

    monkeypatch.setattr(stages, "time", types.SimpleNamespace(perf_counter=lambda: now[0],
                                                              process_time=lambda: now[0]))
    clock = StageClock()
    inner = clock.wrap("planning", lambda: work(0.03))

    def outer():
        work(0.02)
        inner()

    clock.start()
    work(0.005)  # the root's own time, before the first stage
    clock.wrap("decision", outer)()
    clock.stop()
    assert abs(clock.totals["decision"] - 0.02) < 1e-12
    assert abs(clock.totals["planning"] - 0.03) < 1e-12
    assert abs(clock.cpu["planning"] - 0.03) < 1e-12
    assert clock.calls["decision"] == clock.calls["planning"] == 1
    assert abs(sum(clock.totals.values()) - 0.055) < 1e-12  # the root's 0.005 included: a partition


def test_stages_partition_a_short_trial_and_leave_it_unchanged():
    """Every stage non-negative, their sum the measured wall time, every stage that runs in a NOD
    trial seen, and the trial's outcome and simulated time those of the unmeasured trial."""
    scenario = load_scenario("2r-case2").with_overrides(game_players="all")
    times = measure_stages(scenario, seed=1)
    alone = run_trial(scenario, seed=1)
    assert (times.outcome, times.sim_time) == (alone.outcome, alone.sim_time)
    seconds = np.array([times.seconds[k] for k in STAGES])
    assert (seconds >= 0).all()
    assert abs(seconds.sum() - times.wall_time) <= 1e-3 * times.wall_time + 1e-4
    assert (seconds > 0).all()  # each stage has work in a 2-robot NOD trial
    cpu = np.array([times.cpu_seconds[k] for k in STAGES])
    assert (cpu >= 0).all()
    assert abs(cpu.sum() - times.cpu_time) <= 1e-3 * times.cpu_time + 1e-4
    assert times.calls["QP solve"] >= times.calls["control set-up"] > 0
    # The solver is unwrapped again afterwards.
    assert not hasattr(SolverEffort.solve, "__wrapped__")


def test_more_frequent_decisions_put_more_time_into_decision():
    """Deciding every control step instead of every opinion period makes decision a larger share.

    Each trial is 0.1-0.2 s of processor time, so one-off costs landing in either (a compile, a
    cache of the world's built on first use, whatever the process did before) move the shares a
    lot: on a cold compile cache the first trial alone takes 15 s, decision 2.6 % of it. The two
    are therefore measured twice, alternately, and each is judged by its least disturbed run
    (least processor time); the first round doubles as the warm-up."""
    base = load_scenario("2r-case2").with_overrides(game_players="all", time_limit=6.0)
    dt = base.controller.dt
    heavy = base.with_overrides(**{"opinion.T": 2 * dt})
    runs: dict[str, list] = {"base": [], "heavy": []}
    for _ in range(2):
        for name, s in (("base", base), ("heavy", heavy)):
            runs[name].append(measure_stages(s, seed=1))
    share = {}
    for name, measured in runs.items():
        t = min(measured, key=lambda m: m.cpu_time)
        share[name] = t.cpu_seconds["decision"] / t.cpu_time
    assert share["heavy"] > 1.3 * share["base"], share  # five times the decisions; measured 0.085 -> 0.22


def test_cli_prints_the_breakdown_as_json_and_refuses_several_player_counts(capsys):
    """``bench sim --json``: the stages' percents add up to 100 and their processor seconds to the
    measured trials'; ``--players 1,2`` is one line and exit code 2."""
    import json

    from nodnav.cli import main

    assert main(["bench", "sim", "--scenario", "2r-case2", "--trials", "1", "--players", "1", "--json"]) == 0
    (report,) = json.loads(capsys.readouterr().out)
    stages = report["breakdown"]["stages"]
    assert list(stages) == list(STAGES)
    assert abs(sum(v["percent"] for v in stages.values()) - 100.0) < 0.1
    assert abs(report["breakdown"]["sum_of_stages_cpu_s"] - report["breakdown"]["measured_cpu_time_s"]) < 1e-3
    assert main(["bench", "sim", "--players", "1,2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--players" in err[0]


def test_every_solver_call_of_the_controller_is_charged_to_the_qp_stage():
    """The tracking QPs, the certificate LPs and the evasive fallback's least-relaxation LPs all
    count as ``QP solve`` inside :func:`qp_timed`, and the solver's methods are restored after."""
    from nodnav.bench.stages import qp_timed

    before = {name: SolverEffort.__dict__[name] for name in ("solve", "certificate", "relaxation")}
    clock = StageClock()
    rows, lower = np.array([[1.0], [-1.0]]), np.array([1.0, 0.0])  # x >= 1 and x <= 0: infeasible
    with qp_timed(clock):
        effort = SolverEffort()
        effort.solve(np.eye(1), np.zeros(1), rows[:1], lower[:1], 1e-9)
        effort.certificate(rows, lower)
        _, relaxation = effort.relaxation(rows, lower)
    assert clock.calls["QP solve"] == 3
    assert abs(relaxation - 0.5) < 1e-6  # x = 1/2 violates each row by 1/2, the least uniform violation
    assert {name: SolverEffort.__dict__[name] for name in before} == before
