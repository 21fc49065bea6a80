"""The closed-loop benchmark: what it times and how it reports it."""

import numpy as np

from nodnav.bench.closed_loop import benchmark_closed_loop
from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial


def test_benchmark_times_whole_trials_and_reports_their_ratio():
    """Each benchmarked trial is the same trial a sweep would run (same seed, same outcome and
    simulated time), and the speed-up is simulated over wall-clock time."""
    bench = benchmark_closed_loop("2r-case2", seeds=(1,))
    alone = run_trial(load_scenario("2r-case2").with_overrides(game_players="all"), seed=1)
    assert bench.outcomes == (alone.outcome,)
    assert bench.sim_times == (alone.sim_time,)
    np.testing.assert_allclose(bench.speedups, np.array(bench.sim_times) / np.array(bench.wall_times))
    assert bench.setup_time > 0
    assert "2r-case2 with fast, 1 trials" in bench.format()


def test_settings_given_reach_every_benchmarked_trial():
    """``overrides`` (``bench sim --set``) are the trial's settings: the benchmarked trial is the
    trial run alone with them, and a slower robot makes it longer than without them."""
    slow = {"robots[0].max_speed": 0.5}
    bench = benchmark_closed_loop("2r-case2", seeds=(1,), breakdown=False, overrides=slow,
                                  settings=("robots[0].max_speed=0.5",))
    alone = run_trial(load_scenario("2r-case2", slow).with_overrides(game_players="all"), seed=1)
    default = run_trial(load_scenario("2r-case2").with_overrides(game_players="all"), seed=1)
    assert bench.sim_times == (alone.sim_time,) and bench.outcomes == (alone.outcome,)
    assert alone.sim_time > default.sim_time
    assert "(robots[0].max_speed=0.5)" in bench.format()


def test_cli_set_is_for_bench_sim_only_and_checked_before_measuring(capsys):
    """A bad ``--set`` is one line naming it and exit code 2, before anything runs."""
    from nodnav.cli import main

    for argv in (["bench", "mpc", "--set", "controller.horizon=1"],
                 ["bench", "sim", "--set", "controller.horizn=1"],
                 ["bench", "sim", "--set", "planner.name=prm"],
                 ["bench", "sim", "--set", "game_players=2"]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--set" in err[0], (argv, err)
