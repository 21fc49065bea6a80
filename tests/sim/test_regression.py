"""Small deterministic scenarios, one per failure class fixed, each with the seeds that failed.

Each YAML file in ``regression/`` says what went wrong on the commit named in it; here the same
trials must succeed.
"""

from pathlib import Path

import numpy as np
import pytest

from nodnav.scenario.loading import load_scenario
from nodnav.sim.simulator import run_trial

HERE = Path(__file__).parent / "regression"

CASES = [
    ("pair-at-one-mouth.yaml", (4, 5, 9)),
    ("head-on-one-player.yaml", (1, 2, 3, 4)),
    ("exit-past-parked-robots.yaml", (493,)),
    ("start-inside-behind-another.yaml", (308,)),
    ("standoff-abreast-at-the-mouth.yaml", (473, 1, 3)),
    ("destination-in-the-mouth.yaml", (22,)),
    ("squeeze-abreast-at-the-mouth.yaml", (134,)),
    ("squeeze-backing-out-of-the-mouth.yaml", (165,)),
    ("queue-abreast-one-player.yaml", (12,)),
    ("three-against-one-one-player.yaml", (20,)),
    ("race-abreast-into-the-mouth.yaml", (132,)),
    ("waiting-aside-in-a-small-room.yaml", (347,)),
    ("person-at-the-mouth.yaml", (1,)),
    ("person-slow-into-a-narrow-mouth.yaml", (34,)),
    ("accel-0.3-braking-into-the-wall-2-robots.yaml", (1,)),
    ("accel-0.3-braking-into-the-wall-4-robots.yaml", (1,)),
    ("accel-0.15-braking-into-the-wall.yaml", (1,)),
    ("accel-0.5-braking-into-the-wall.yaml", (1,)),
    ("doorway-small-slow-robots.yaml", (1,)),
    ("head-on-inside.yaml", (0, 1, 2, 3)),
    ("teams-head-on-inside.yaml", (0, 1, 2)),
    ("bay-head-on-inside.yaml", (0, 1, 2)),
    ("back-out-into-a-low-room.yaml", (171,)),
    ("swap-through-a-small-middle-room.yaml", (1, 2, 3, 8)),
    ("overshoot-slow-robot-behind-a-fast-one.yaml", (5,)),
    ("overshoot-three-robots-short-corridor.yaml", (178,)),
    ("overshoot-slow-robot-head-on.yaml", (74,)),
    ("person-thrown-across-a-narrow-mouth.yaml", (262,)),
    ("person-turning-slowly-into-a-mouth.yaml", (480,)),
    ("person-at-its-destination-by-the-mouth.yaml", (5,)),
    ("person-facing-a-robot-coming-out.yaml", (300,)),
    ("person-beside-a-waiting-robot.yaml", (32,)),
    ("person-swaying-at-a-vertex.yaml", (132,)),
    ("person-standing-aside-for-a-waiting-robot.yaml", (35,)),
    ("head-on-in-limited-sight.yaml", (6, 12)),
    ("sight-remembered-robot-collision.yaml", (1,)),
    ("abreast-after-backing-out.yaml", (66,)),
    ("standoff-with-an-arrived-robot.yaml", (1, 17)),
    ("wait-cycle-at-the-mouth.yaml", (133,)),
    ("wait-chain-at-the-right-mouth.yaml", (193,)),
    ("destination-behind-parked-robots.yaml", (1,)),
    ("destination-behind-parked-robots-in-the-room.yaml", (1,)),
    ("occluded-mouth-robot-steps-out.yaml", (222,)),
    ("occluded-mouth-slow-braker.yaml", (417,)),
    ("crossed-rule-with-another-passage-ahead.yaml", (473,)),
    ("press-and-back-off-in-turn.yaml", (5, 24)),
    ("mirror-abreast-both-first.yaml", (20, 23, 26)),
    ("committed-tail-into-a-stopped-robot.yaml", (182,)),
    ("braking-off-the-committed-trajectory.yaml", (189,)),
    ("slow-braker-among-hard-brakers-inside.yaml", (115,)),
    ("knot-at-the-mouth-one-player.yaml", (35, 61, 98, 99, 197)),
    ("knot-at-the-mouth-skipping.yaml", (4, 19)),
]


@pytest.mark.parametrize("name, seeds", CASES, ids=[c[0].removesuffix(".yaml") for c in CASES])
def test_trials_that_failed_now_succeed(name, seeds):
    scenario = load_scenario(HERE / name)
    for seed in seeds:
        result = run_trial(scenario, seed=seed)
        assert result.outcome == "success", f"{name} seed {seed}: {result.outcome} at {result.sim_time:.1f} s"
        # No two bodies ever overlapped (radii may differ: pair by pair, at every recorded step).
        positions = np.array(result.history.positions)
        a, b = np.triu_indices(scenario.n_robots, k=1)
        gaps = np.linalg.norm(positions[:, a] - positions[:, b], axis=2) - scenario.radii[a] - scenario.radii[b]
        assert gaps.min() >= -scenario.sim.collision_tolerance
