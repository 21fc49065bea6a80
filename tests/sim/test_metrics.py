"""Metrics against hand computations on synthetic histories (docs/metrics.md)."""

import json
import math

import numpy as np
import pytest

from nodnav.scenario.schema import scenario_from_dict
from nodnav.scenario.world import paper_world
from nodnav.sim.history import History
from nodnav.sim.metrics import (
    compute_metrics,
    corridor_crossings,
    flow_rate,
    json_ready,
    min_separation,
    opinion_switches,
    smoothness,
    time_to_consensus,
)

DT = 0.1


def _scenario(origins, destinations, goal_tolerance=0.12):
    return scenario_from_dict({
        "name": "synthetic",
        "robots": [{"origin": list(o), "destination": list(d)} for o, d in zip(origins, destinations)],
        "sim": {"goal_tolerance": goal_tolerance},
    })


def _history(scenario, times, positions, velocities=None, decision_times=(), strategies=(), outcome="success"):
    positions = np.asarray(positions, dtype=float)
    if velocities is None:
        velocities = np.gradient(positions, times, axis=0)
    h = History(scenario=scenario, method="nod", seed=0, outcome=outcome)
    h.times = list(times)
    h.positions = list(positions)
    h.velocities = list(np.asarray(velocities, dtype=float))
    h.decision_times = list(decision_times)
    h.strategies = [np.asarray(s) for s in strategies]
    return h


def _two_straight_robots(outcome="success"):
    """Robot 1: (-5, 0) -> (5, 0) at 1 m/s; robot 2: (5, 0.1) -> (0, 0.1) at 0.5 m/s; both stop at t = 10, end at 12."""
    t = np.round(np.arange(0, 121) * DT, 10)
    s = np.minimum(t, 10.0)
    p1 = np.stack([-5.0 + s, np.zeros_like(s)], axis=-1)
    p2 = np.stack([5.0 - 0.5 * s, np.full_like(s, 0.1)], axis=-1)
    sc = _scenario([(-5, 0), (5, 0.1)], [(5, 0), (0, 0.1)])
    return _history(sc, t, np.stack([p1, p2], axis=1), outcome=outcome)


def test_straight_lines_at_constant_speed():
    m = compute_metrics(_two_straight_robots())
    # Robot 1 is within 0.12 m of x = 5 once x >= 4.88, i.e. t >= 9.88: first sample 9.9 s.
    # Robot 2 is within 0.12 m of x = 0 once 5 - 0.5 t <= 0.12, i.e. t >= 9.76: first sample 9.8 s.
    assert m["time_to_goal_s"] == pytest.approx([9.9, 9.8])
    assert m["makespan_s"] == pytest.approx(9.9)
    # Straight motion: lengths equal the straight distances 10 m and 5 m.
    assert m["path_length_m"] == pytest.approx([10.0, 5.0])
    assert m["path_deviation_m"] == pytest.approx([0.0, 0.0], abs=1e-9)
    assert m["path_ratio"] == pytest.approx([1.0, 1.0])
    # At time t the gap is (10 - 1.5 t, 0.1) until t = 10, so the closest approach is at t = 20/3,
    # between samples, where the distance is exactly the 0.1 m lateral offset.
    assert m["min_separation_m"] == pytest.approx(0.1, abs=1e-12)


def test_makespan_is_undefined_unless_the_trial_succeeded():
    m = compute_metrics(_two_straight_robots(outcome="collision"))
    assert math.isnan(m["makespan_s"])
    assert m["time_to_goal_s"] == pytest.approx([9.9, 9.8])


def test_u_shaped_square_path():
    # Three sides of a 2 m square from (-6, -1) to (-6, 1): length 6 m against 2 m straight.
    side = np.linspace(0, 2, 21)
    pts = np.concatenate([
        np.stack([-6 + side, -1 + 0 * side], -1),
        np.stack([-4 + 0 * side[1:], -1 + side[1:]], -1),
        np.stack([-4 - side[1:], 1 + 0 * side[1:]], -1),
    ])
    other = np.tile([[5.0, 0.0]], (len(pts), 1))
    sc = _scenario([(-6, -1), (5, 0)], [(-6, 1), (5.5, 0)])
    t = np.arange(len(pts)) * DT
    m = compute_metrics(_history(sc, t, np.stack([pts, other], axis=1), outcome="timeout"))
    assert m["path_length_m"][0] == pytest.approx(6.0)
    assert m["path_deviation_m"][0] == pytest.approx(4.0)
    assert m["path_ratio"][0] == pytest.approx(3.0)
    # The parked robot moved nowhere: length 0, deviation minus its 0.5 m straight distance.
    assert m["path_length_m"][1] == 0.0
    assert m["path_deviation_m"][1] == pytest.approx(-0.5)
    # Within 0.12 m of (-6, 1) from the sample at (-5.9, 1), the one before the last.
    assert m["time_to_goal_s"][0] == pytest.approx(t[-2])
    assert math.isnan(m["time_to_goal_s"][1])


def test_min_separation_is_exact_between_samples():
    # Head-on pair on parallel lines 0.5 m apart, closing at 2 m/s; they are level at t = 1.025 s,
    # which is no sample time. Exact minimum: 0.5 m. Best sample (t = 1.0): sqrt(0.05^2 + 0.5^2).
    t = np.arange(0, 21) * DT
    a = np.stack([-1.0 + t, 0 * t], -1)
    b = np.stack([1.05 - t, 0.5 + 0 * t], -1)
    p = np.stack([a, b], axis=1)
    sampled = math.hypot(0.05, 0.5)
    assert min_separation(p) == pytest.approx(0.5, abs=1e-12)
    assert min_separation(p) < sampled - 1e-3
    # A pair that never approaches: the minimum is the first sample.
    assert min_separation(np.stack([a, a + [0, 3]], axis=1)) == pytest.approx(3.0)
    assert min_separation(p[:, :1]) == math.inf


def test_min_separation_of_three_robots_takes_the_closest_pair():
    t = np.arange(0, 11) * DT
    still = np.zeros((len(t), 2))
    # Robot 2 passes robot 1 at 0.3 m; robot 3 stays 2 m away from both.
    passing = np.stack([-0.55 + t, 0.3 + 0 * t], -1)
    far = np.tile([0.0, 2.0], (len(t), 1))
    p = np.stack([still, passing, far], axis=1)
    assert min_separation(p) == pytest.approx(0.3, abs=1e-12)


def test_corridor_crossing_times_are_interpolated():
    world = paper_world()
    # x = -5 + t crosses x = -3 at t = 2 and x = 3 at t = 8; a coarse 0.3 s step falls on neither.
    t = np.arange(0, 35) * 0.3
    t_in, t_out = corridor_crossings(t, -5.0 + t, world)
    assert t_in == pytest.approx([2.0]) and t_out == pytest.approx([8.0])
    # Enters and backs out: no crossing.
    x = -5.0 + 3.0 - np.abs(t - 3.0)
    assert len(corridor_crossings(t, x, world)[0]) == 0
    # Starts inside the corridor and leaves: no crossing.
    assert len(corridor_crossings(t, 0.0 + t, world)[0]) == 0


def test_flow_rate_of_two_robots_one_after_the_other():
    world = paper_world()
    t = np.arange(0, 201) * DT
    # Robot 1 crosses left to right: in at 2 s, out at 8 s. Robot 2 waits at x = 6 until 8 s, then
    # crosses right to left at 1 m/s: in at 11 s, out at 17 s. Robot 3 enters at 1 s and backs out.
    x1 = -5.0 + np.minimum(t, 10.0)
    x2 = 6.0 - np.clip(t - 8.0, 0.0, 12.0)
    x3 = -4.0 + np.where(t < 2.0, t, np.maximum(4.0 - t, -1.0))
    p = np.stack([np.stack([x, 0 * t], -1) for x in (x1, x2, x3)], axis=1)
    crossed, rate = flow_rate(t, p, world)
    assert crossed == 2
    assert rate == pytest.approx(2.0 / (17.0 - 2.0))
    none_crossed, undefined = flow_rate(t, p[:, 2:], world)
    assert none_crossed == 0 and math.isnan(undefined)


def test_smoothness_hand_computed():
    # Robot 1 turns once from (1, 0) to (0, 1) m/s: one change of |(-1, 1)| = sqrt 2.
    # Robot 2 keeps (0.5, 0.5) m/s. Mean over 2 robots x 9 steps: sqrt(2) / 18.
    v1 = np.array([[1.0, 0.0]] * 5 + [[0.0, 1.0]] * 5)
    v2 = np.array([[0.5, 0.5]] * 10)
    assert smoothness(np.stack([v1, v2], axis=1)) == pytest.approx(math.sqrt(2) / 18)
    assert math.isnan(smoothness(v1[:1, None]))


def test_smoothness_of_uniform_circular_motion():
    # Speed 1 m/s on a circle, turning omega = 0.5 rad/s: every step the velocity turns by
    # omega dt, so |dv| = 2 sin(omega dt / 2) exactly.
    omega = 0.5
    t = np.arange(0, 50) * DT
    v = np.stack([-np.sin(omega * t), np.cos(omega * t)], -1)[:, None]
    assert smoothness(v) == pytest.approx(2 * math.sin(omega * DT / 2), rel=1e-12)


STRATEGIES = np.array([[0, 2, 1],
                       [0, 2, 0],
                       [1, 2, 0],
                       [1, 1, 1],
                       [1, 1, 1]])


def test_opinion_switches_count_changes_per_robot():
    # Robot 1: 0,0,1,1,1 -> 1 change; robot 2: 2,2,2,1,1 -> 1; robot 3: 1,0,0,1,1 -> 2.
    assert opinion_switches(STRATEGIES).tolist() == [1, 1, 2]
    assert opinion_switches(STRATEGIES[:1]).tolist() == [0, 0, 0]


def test_time_to_consensus_is_the_start_of_the_last_agreement():
    times = np.arange(5) * 1.0
    assert time_to_consensus(times, STRATEGIES) == 3.0
    # Agreement at the start, lost, then regained: the regained one counts.
    s = np.array([[4, 4], [4, 5], [5, 5], [5, 5]])
    assert time_to_consensus(times[:4], s) == 2.0
    assert time_to_consensus(times[:2], np.array([[1, 1], [1, 1]])) == 0.0
    assert math.isnan(time_to_consensus(times[:2], np.array([[1, 1], [1, 0]])))
    assert math.isnan(time_to_consensus(times[:2], np.full((2, 2), -1)))
    assert math.isnan(time_to_consensus(times[:0], np.zeros((0, 2), dtype=int)))


def test_time_to_consensus_counts_only_the_open_part_of_the_order():
    # Three robots; S1 = (1,2,3), S3 = (2,1,3), S4 = (2,3,1). Robot 2 enters after the second
    # decision. Before that robots choose S1 / S3 (disagreeing on who goes first); after it,
    # S3 and S4 still disagree on 1 versus 3 but S3 and S1 agree (1 before 3).
    times = np.arange(4) * 1.0
    s = np.array([[0, 2, 2], [2, 2, 2], [2, 0, 2], [3, 2, 3]])
    undecided = np.array([[1, 1, 1], [1, 1, 1], [1, 0, 1], [1, 0, 1]], dtype=bool)
    assert math.isnan(time_to_consensus(times, s, undecided))
    s[3] = [2, 0, 0]
    assert time_to_consensus(times, s, undecided) == 1.0
    # Once fewer than two robots are left to enter, later decisions do not count.
    undecided[3] = [1, 0, 0]
    s[3] = [5, 4, 3]
    assert time_to_consensus(times, s, undecided) == 1.0


def test_compute_metrics_decisions_and_json():
    h = _two_straight_robots()
    h.decision_times = [0.0, 1.0, 2.0]
    h.strategies = [np.array([0, 1]), np.array([1, 1]), np.array([1, 1])]
    # The same selections as orders (ranks): strategy 0 is (1,2), strategy 1 is (2,1).
    h.ranks = [np.array([[0, 1], [1, 0]]), np.array([[1, 0], [1, 0]]), np.array([[1, 0], [1, 0]])]
    h.undecided = [np.array([True, True])] * 3
    m = compute_metrics(h)
    assert m["opinion_switches"] == 1 and m["opinion_switches_per_robot"] == [1, 0]
    assert m["time_to_consensus_s"] == 1.0
    # Robot 1 crosses (in at 2 s, out at 8 s); robot 2 stops at x = 0 inside the corridor.
    assert m["robots_crossed"] == 1 and m["flow_rate_rps"] == pytest.approx(1 / 6)
    text = json.dumps(json_ready(m), allow_nan=False)
    assert json.loads(text)["makespan_s"] == pytest.approx(9.9)


def test_json_ready_replaces_non_finite_values():
    value = {"a": float("nan"), "b": [1.0, float("inf"), np.float64(2.5)], "c": np.int64(3),
             "d": np.array([np.nan, 1.0]), "e": np.bool_(True), "f": "text", "g": None}
    out = json_ready(value)
    assert out == {"a": None, "b": [1.0, None, 2.5], "c": 3, "d": [None, 1.0], "e": True, "f": "text", "g": None}
    assert type(out["c"]) is int and type(out["e"]) is bool
    json.dumps(out, allow_nan=False)


def test_metrics_of_a_real_trial_agree_with_the_simulator():
    from nodnav.scenario.loading import load_scenario
    from nodnav.sim.simulator import CONTACT_SUBSTEPS, run_trial

    result = run_trial(load_scenario("2r-case1"), seed=2)
    m = compute_metrics(result.history)
    # The simulator records arrivals while it runs; the metric finds them again in the history.
    assert m["time_to_goal_s"] == pytest.approx(list(result.time_to_goal), nan_ok=True)
    if result.success:
        assert m["makespan_s"] == pytest.approx(result.makespan)
    # The simulator samples each step at CONTACT_SUBSTEPS points; robots close at most 2 m/s, so
    # its minimum exceeds the exact one by at most half a sub-step of relative motion.
    half_substep = 0.5 * 2 * 1.0 * result.history.scenario.controller.dt / CONTACT_SUBSTEPS
    assert result.min_separation - half_substep <= m["min_separation_m"] <= result.min_separation + 1e-12
    if result.success:
        assert m["robots_crossed"] == 2
    json.dumps(json_ready(m), allow_nan=False)


def _two_passage_history():
    """Passage A along x from (-5, 0) to (-2, 0), passage B along y from (3, 2) to (3, 5), both
    0.7 m wide; three robots on axis-parallel polylines at 1 m/s, sampled every 0.1 s:

    - robot 1: (-7, 0) -> (0, 0) -> (3, 0) -> (3, 7): A left to right (in at x = -5, t = 2; out at
      x = -2, t = 5), then B upwards (in at y = 2, t = 12; out at y = 5, t = 15);
    - robot 2: (3, 7) -> (3, 0) -> (-7, 0): B downwards (in at y = 5, t = 2; out at y = 2, t = 5),
      then A right to left (in at x = -2, t = 12; out at x = -5, t = 15);
    - robot 3: (-7, 3.5) -> (0, 3.5): along A's axis through x = -5..-2 and across B's band
      y = 2..5, but 3.5 m off A's centreline and 3 m or more off B's: it crosses neither.
    """
    from dataclasses import replace

    from nodnav.scenario.world import Passage, World

    t = np.round(np.arange(0, 201) * DT, 10)

    def polyline(points):
        points = np.asarray(points, dtype=float)
        at = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        return np.stack([np.interp(t, at, points[:, 0]), np.interp(t, at, points[:, 1])], axis=-1)

    paths = [polyline([(-7, 0), (0, 0), (3, 0), (3, 7)]), polyline([(3, 7), (3, 0), (-7, 0)]),
             polyline([(-7, 3.5), (0, 3.5)])]
    # The robots' origins and destinations (in the paper's world, which the world below replaces)
    # do not enter the crossing metrics.
    sc = _scenario([(-5, 0), (5, 0), (-5, 1)], [(5, 0), (-5, 0), (5, 1)])
    world = World(bounds=(-8.0, -1.0, 8.0, 8.0), obstacles=(),
                  passages=(Passage(start=(-5.0, 0.0), end=(-2.0, 0.0), width=0.7),
                            Passage(start=(3.0, 2.0), end=(3.0, 5.0), width=0.7)))
    return _history(replace(sc, world=world), t, np.stack(paths, axis=1))


def test_crossings_entry_order_and_flow_per_passage_of_several():
    m = compute_metrics(_two_passage_history())
    a_times, b_times = m["passage_entry_times_s"]
    assert a_times[:2] == pytest.approx([2.0, 12.0]) and math.isnan(a_times[2])
    assert b_times[:2] == pytest.approx([12.0, 2.0]) and math.isnan(b_times[2])
    assert m["passage_entry_orders"] == [[1, 2], [2, 1]]  # robot numbers from 1, per passage
    assert m["passage_robots_crossed"] == [2, 2]  # robot 3 passes beside both, crosses neither
    assert m["passage_flow_rate_rps"] == pytest.approx([2.0 / (15.0 - 2.0), 2.0 / (15.0 - 2.0)])
    # The trial's headline crossing numbers are the first passage's.
    assert m["robots_crossed"] == 2 and m["flow_rate_rps"] == pytest.approx(2.0 / 13.0)
    # Along A's axis alone (the one-passage rule), robot 3 would count as crossing it.
    assert flow_rate(np.asarray(_two_passage_history().times), _two_passage_history().arrays()["positions"],
                     _two_passage_history().scenario.world)[0] == 3


def test_a_crossing_broken_by_a_sample_beside_the_passage_does_not_count():
    from nodnav.scenario.world import Passage
    from nodnav.sim.metrics import AWAY, passage_crossings, passage_states

    g = Passage(start=(3.0, 2.0), end=(3.0, 5.0), width=0.7)
    assert passage_states(np.array([[3.0, 1.0], [3.3, 3.0], [3.4, 3.0], [0.0, 3.0], [2.0, 6.0]]), g).tolist() == [
        -1, 0, AWAY, AWAY, 1]
    t = np.arange(5.0)
    # Below, inside, beside (off the rectangle), inside, above: no complete crossing.
    p = np.array([[3.0, 1.0], [3.0, 3.0], [4.0, 3.5], [3.0, 4.0], [3.0, 6.0]])
    assert len(passage_crossings(t, p, g)[0]) == 0
    # Without the detour it is one, in at y = 2 (t = 0.5), out at y = 5 (t = 3.5).
    p[2] = (3.0, 3.5)
    t_in, t_out = passage_crossings(t, p, g)
    assert t_in == pytest.approx([0.5]) and t_out == pytest.approx([3.5])


def test_one_passage_adds_no_per_passage_metrics():
    assert not [k for k in compute_metrics(_two_straight_robots()) if k.startswith("passage_")]


def test_the_snapshot_title_names_the_order_of_each_passage():
    from nodnav.viz.trial import passage_orders_text

    assert passage_orders_text(_two_passage_history()) == "; crossed passage 1: 1,2; passage 2: 2,1"
    assert passage_orders_text(_two_straight_robots()) == ""
