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
