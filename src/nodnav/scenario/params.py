"""The parameters of a scenario: frozen dataclasses, one per part, each field with its unit and paper value.

Planners and controllers each have their own parameter class, derived from
:class:`PlannerParams` or :class:`ControllerParams` and chosen by ``name`` in the scenario file;
the built-in ones are declared here, in the registries of :mod:`nodnav.registry`, so that a
scenario is validated when it is loaded without importing any planner or controller. Every
number declares its accepted range on its field (``metadata=accepted(...)``, :mod:`nodnav.scenario.limits`),
as a plugin's parameters do; the size limits and the rules between fields are in :mod:`nodnav.scenario.schema`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from nodnav.registry import CONTROLLERS, PLANNERS
from nodnav.scenario.fields import strategy_name_index
from nodnav.scenario.limits import MAX_WORLD_SIZE, accepted


@dataclass(frozen=True)
class OpinionParams:
    """Parameters of the opinion layer (Sections II-B and III)."""

    u: float = field(default=100.0, metadata=accepted(0.0, 1e4))
    """Attention u_i to the social term (dimensionless); paper: 100 (10 for Fig. 2b/2c)."""
    d: float = field(default=1.0, metadata=accepted(0.0, 2.0, False, why="the update (8) diverges above 2"))
    """Resistance d_i, the inverse time constant of the opinion (1/s); paper: 1."""
    eta: float = field(default=1.0, metadata=accepted(0.001, 1e3))
    """Softmax temperature eta of eq. (3) (dimensionless); paper: 1."""
    K1: float = field(default=5.0, metadata=accepted(0.0, 1e3))
    """Scaling K_1 of the observed-versus-planned deviation in eq. (4) (1/(m^2 s)); paper: 5."""
    T: float = field(default=1.0, metadata=accepted(0.0, 60.0, False, why="a whole multiple of controller.dt"))
    """Opinion period T: decisions and the estimation window of eq. (4) (s); paper: 1."""
    alpha_min: float = field(default=0.05, metadata=accepted(0.0, 1.0, False))
    """Lower bound h of the step size alpha(t) = max(1/(t+1), h) of eq. (8); paper: 0.05."""
    init: Literal["zero", "distance", "given"] = "zero"
    """Initial opinions: ``zero`` (z_ij(0) = 0), ``distance`` (eqs. (10)-(11)) or ``given`` (``z0``); paper: zero."""
    z0: tuple[tuple[float, ...], ...] = field(default=(), metadata=accepted(-1e6, 1e6))
    """With ``init: given``, the initial opinions z_i(0) of every robot, one row per robot (dimensionless)."""
    K2: float = field(default=10.0, metadata=accepted(0.0, 1e3))
    """Scaling K_2 of the distance-based initial opinions, eq. (11) (dimensionless); paper: 10."""
    delta: float = field(default=1.0, metadata=accepted(0.001, 1e3))
    """Offset delta of the conflict likelihood, eq. (6) (m); paper: 1."""
    bias: dict[str, float] = field(default_factory=dict, metadata=accepted(-1e6, 1e6, why="keys ``S1`` .. ``S<N_r!>``"))
    """Bias b_ij per strategy name, e.g. ``{S3: 150, S5: 150}`` (dimensionless); paper: none."""
    conflict: Literal["paper", "undecided"] = "paper"
    """Game-player selection, eqs. (6)-(7): ``paper`` (every other robot a candidate) or
    ``undecided`` (robots seen in the corridor only when too few others are left)."""
    standoff_patience: float = field(default=2.0, metadata=accepted(0.0, 600.0))
    """After how long a standoff with a game player (neither progressing, although the robot's
    plan has one of them progress) the lower-numbered robot of the two goes first (s); 0 never (the paper)."""
    standoff_progress: Literal["period", "best"] = "best"
    """How a standoff judges a robot's progress over a period: ``best`` (beyond the closest to its
    destination it came over the last ``standoff_patience``, so that pressing and backing off in
    turn is no progress) or ``period`` (over the period alone, as before; docs/sight-standoffs.md)."""
    estimation: Literal["paper", "reachable", "mismatch"] = "mismatch"
    """How eq. (4) reads a plan: ``paper`` (the planned states as they are) or ``reachable`` (the
    planned motion as the observed robot can carry it out from its observed state at the start of
    the window, its velocity changing at most at its ``max_accel``) or ``mismatch`` (the planned
    motion shifted by the observed robot's initial mismatch with it, the mismatch shrinking at its
    ``max_accel``; the default: ``reachable`` counts the limit twice with ``planner.timing:
    feasible``, docs/safety.md)."""
    nonplayers: Literal["static", "entered"] = "entered"
    """How robots outside N_i(t) enter the robot's planning: ``static`` (the paper: not planned,
    held still in the MPC) or ``entered`` (those seen inside the corridor are planned too, at the
    front of the order, where history has put them; not with 0 game players, the paper's
    no-coordination case)."""
    crossed: Literal["ignore", "planned"] = "planned"
    """With ``nonplayers: entered``, how robots outside N_i(t) that have crossed (outside the
    corridor, on their destination's side: parked, or on their way to park) enter the robot's
    planning: ``ignore`` (not planned, kept clear of by the MPC alone, as before) or ``planned``
    (those packed round the way of a robot of the plan are planned too, at the front of
    the order, so that the planner routes round them or has them wait aside and park again;
    docs/execution.md, "Parked robots making way in crowds")."""

    def bias_indices(self) -> dict[int, float]:
        """The bias b_ij as a mapping from strategy index (0-based: S1 is 0) to value."""
        return {strategy_name_index(name): float(value) for name, value in self.bias.items()}

    def bias_vector(self, n_strategies: int) -> np.ndarray:
        """The bias b_i as an array over strategies S1..S_{N_s}."""
        b = np.zeros(n_strategies)
        for name, value in self.bias.items():
            b[strategy_name_index(name)] = value
        return b


@dataclass(frozen=True)
class RobotSpec:
    """One robot: where it starts, where it goes, and its body."""

    origin: tuple[float, float]
    """Origin O_i (m)."""
    destination: tuple[float, float]
    """Destination D_i (m)."""
    radius: float = field(default=0.2, metadata=accepted(0.01, 5.0, why="below the corridor's clearance"))
    """Body radius r_robot (m); paper: not given, 0.2 chosen (docs: Scenarios, "Choices the paper leaves open")."""
    max_speed: float = field(default=1.0, metadata=accepted(0.05, 5.0))
    """Speed limit (m/s); paper: 1."""
    max_accel: float = field(default=2.0, metadata=accepted(
        0.1, 50.0, why="every accepted value is safe (the braking tail); below, a robot needs tens of metres to stop"))
    """Acceleration limit used by the MPC (m/s^2); paper: not given."""
    opinion: OpinionParams | None = None
    """This robot's own opinion parameters; ``None`` means the scenario's ``opinion``."""
    method: str | None = None
    """This robot's navigation method (a name of :data:`~nodnav.registry.METHODS`, e.g. ``person``);
    ``None`` means the trial's method (``--method``, default ``nod``)."""


@dataclass(frozen=True)
class PlannerParams:
    """What every multi-robot path planner is given: its name and the settings all planners share.

    Each planner derives its own parameters from this class and registers them under its name
    (:data:`~nodnav.registry.PLANNERS`); ``planner.name`` in a scenario chooses the class.
    """

    name: str = "fast"
    """Planner name, one of :data:`~nodnav.registry.PLANNERS` (``fast``, ``prm``, or a plugin's)."""
    dt: float = field(default=0.1, metadata=accepted(0.01, 1.0, why="at most MAX_PLAN_STEPS steps across the world"))
    """Time step of the planned joint trajectory (s)."""
    margin: float = field(default=0.05, metadata=accepted(0.0, 0.5))
    """Extra separation kept by the planner beyond 2 r_robot (m)."""
    door_clearance: float = field(default=1.0, metadata=accepted(0.0, 10.0))
    """Radius of the zone around a corridor entrance kept clear while a robot comes out of it,
    and that a robot with no plan gets out of (:mod:`nodnav.planning.clearing`) (m)."""
    clearing_radii: tuple[float, ...] = field(default=(0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0),
                                              metadata=accepted(0.01, MAX_WORLD_SIZE))
    """Radii of the rings of spots a robot with no plan tries to clear the way to, nearest first (m)."""
    clearing_directions: int = field(default=16, metadata=accepted(1, 360))
    """Spots per ring of ``clearing_radii``."""
    inside: Literal["back-out", "literal"] = "back-out"
    """Robots inside the passage heading opposite ways: either may go first and the other backs
    out (``back-out``, issue 19, the fast planner), or they keep the order they entered in
    (``literal``, as before; the PRM planner always does); see docs/meet-inside.md."""
    timing: Literal["feasible", "speed-only"] = "feasible"
    """Paths timed within each robot's speed and acceleration limits (``feasible``, issue 18), or
    by speed alone (``speed-only``, as before: 0, 1 or 2 cells a step, PRM* at full speed); docs/safety.md."""


@PLANNERS.declare("fast", help="prioritised planning in space-time, no precomputation (default)")
@dataclass(frozen=True)
class FastPlannerParams(PlannerParams):
    """The fast planner's settings (:mod:`nodnav.planning.prioritized`)."""

    reuse_tolerance: float = field(default=0.05, metadata=accepted(0.0, 1.0))
    """Speed setting (m), 0.05 by default since the thirteenth round (docs/performance-15.md): a query
    asked again one round later keeps the round before's plan of it, carried on to now, while every
    robot stands within this distance of where that plan has it (plus the drift its velocity error
    adds, braked away at its acceleration limit, ``|dv|^2 / 2a``). 0.05 m is ``execution.tolerance``,
    within which a robot counts as at its planned sample, and a cell of this planner at 1 m/s
    (``v_max dt / 2``); 0: Algorithm 1 as written, every strategy planned from X(t) each period.
    Fast planner only: a kept PRM* plan would keep its old path cost."""

    waiting: Literal["early", "late"] = "early"
    """A yielding robot holds back ``early`` (legible) or drives up and waits ``late``."""
    retreat_radii: tuple[float, ...] = field(default=(0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0),
                                             metadata=accepted(0.01, MAX_WORLD_SIZE))
    """Radii of the rings of candidate spots a cornered robot may back out to (m); the largest
    reaches a room from anywhere in a corridor of the paper's length."""
    retreat_angles: int = field(default=16, metadata=accepted(1, 360))
    """Directions per ring of candidate spots."""
    retreat_tries: int = field(default=8, metadata=accepted(1, 100))
    """How many of the nearest candidate spots are tried before giving up."""
    cascade: int = field(default=2, metadata=accepted(0, 6))
    """How many robots deep a robot that must get out of the way may first move others out of its way."""


def plan_reuse(planner: PlannerParams) -> tuple[float, float]:
    """How far (m) the robots may be from a query's plan of the round before for the plan cache to
    keep it, and the planned trajectory's time step (s): the fast planner's ``reuse_tolerance``;
    0 (every query planned anew each round) for any other planner, whose plans' costs the cache
    could not carry on to a later start."""
    return (planner.reuse_tolerance if isinstance(planner, FastPlannerParams) else 0.0), planner.dt


@PLANNERS.declare("prm", help="PRM* roadmaps in the joint space, the paper's planner (roadmaps cached on disk)")
@dataclass(frozen=True)
class PRMParams(PlannerParams):
    """PRM*'s settings (:mod:`nodnav.planning.prm`, appendix)."""

    w1: float = field(default=0.4, metadata=accepted(0.0, 1e3))
    """Weight w_1 of the proximity penalty in the PRM* path cost (1/m); paper: 0.4."""
    varsigma: float = field(default=0.1, metadata=accepted(0.0, 1.0))
    """Safety margin varsigma of Phi_proximity (m); paper: 0.1."""
    roadmap_vertices: int = field(default=2000, metadata=accepted(10, 10000))
    """Roadmap size is this times the number of robots (vertices); 500 already answers every built-in query."""
    cache_dir: str = ""
    """Roadmap cache directory; empty means ``$NODNAV_CACHE`` or ``~/.cache/nodnav``."""
    connect_factor: int = field(default=3, metadata=accepted(1, 100))
    """A query's start and goal are offered this many times PRM*'s k nearest roadmap vertices."""
    link_widening: int = field(default=8, metadata=accepted(1, 100))
    """When none of those can be linked, this many times as many are tried, then all."""


@dataclass(frozen=True)
class ControllerParams:
    """What every motion controller is given: its name and the settings the simulation shares with it.

    Each controller derives its own parameters from this class and registers them under its
    name (:data:`~nodnav.registry.CONTROLLERS`); ``controller.name`` chooses the class.
    """

    name: str = "mpc"
    """Controller name, one of :data:`~nodnav.registry.CONTROLLERS` (``mpc``, or a plugin's)."""
    dt: float = field(default=0.1, metadata=accepted(0.01, 1.0, why="at most controller.horizon"))
    """Control and physics step (s)."""
    horizon: float = field(default=0.8, metadata=accepted(0.01, 5.0))
    """Horizon over which the controller is given the others' predicted motion, T_MPC (s); paper: 0.8."""
    samples: int = field(default=8, metadata=accepted(1, 100))
    """Instants over the horizon at which the others' predicted motion is given (evenly spaced, the
    last at the horizon); the MPC keeps clear of the predictions there and between them."""
    safety_margin: float = field(default=0.02, metadata=accepted(0.0, 0.5))
    """Separation the controller keeps beyond 2 r_robot (m), which the simulation's reaction margin
    leaves free too; below the planner's ``margin`` so that plans that keep exactly that can be
    tracked (not in the paper)."""


@CONTROLLERS.declare("mpc", help="the B-spline model predictive controller of the appendix (default)")
@dataclass(frozen=True)
class MPCParams(ControllerParams):
    """The B-spline MPC (:mod:`nodnav.control.mpc`, appendix): the paper's weights, then its
    numerical choices (not in the paper; the defaults are the tested ones)."""

    w2: float = field(default=1e-6, metadata=accepted(0.0, 1e3))
    """Velocity weight w_2 of the MPC cost (s^2); paper: 1e-6."""
    segments: int = field(default=8, metadata=accepted(2, 64))
    """Knot spans of the cubic B-spline over the horizon (one per 0.1 s for T_MPC = 0.8 s)."""
    max_interval: float = field(default=0.05, metadata=accepted(0.01, 1.0))
    """Longest time between separation / wall constraint samples (s)."""
    speed_polygon_sides: int = field(default=16, metadata=accepted(4, 64))
    """Sides of the inscribed polygon bounding the velocity (98 % of the limit across a face)."""
    accel_polygon_sides: int = field(default=8, metadata=accepted(4, 64))
    """Sides of the inscribed polygon bounding the acceleration (92 % of the limit across a face)."""
    terminal_pieces: int = field(default=4, metadata=accepted(1, 32))
    """Secants approximating the stopping-distance parabola of the terminal constraint."""
    terminal_decel: float = field(default=0.7, metadata=accepted(0.0, 1.0, False))
    """Fraction of the available deceleration assumed by the terminal constraint (headroom for
    the approximations of the next step)."""
    sqp_iterations: int = field(default=2, metadata=accepted(1, 10))
    """QPs solved per step at most after a cold start (each re-linearised about the previous
    QP's solution); one otherwise."""
    sqp_tolerance: float = field(default=0.02, metadata=accepted(0.0, 1.0))
    """A further QP is solved when the solution moved farther than this from its linearisation (m)."""
    qp_tolerance: float = field(default=1e-9, metadata=accepted(1e-12, 0.001))
    """Largest row violation the QP solver accepts (DAQP's primal tolerance, m); every inequality
    is tightened by it. DAQP's default (1e-6) left rows violated by up to 1e-6 m."""
    evasive: bool = True
    """Whether a failed tracking QP is followed by the evasive QP (else the robot brakes at once,
    the controller's earlier behaviour, kept for comparison)."""
    skip_unpassable: bool = True
    """Whether the MPC brakes without solving where no plan can pass mutual braking
    (:func:`~nodnav.control.mpc_braking.no_plan_passes`): the same decision at that step, half the
    QP time in crowds. Later trajectories differ in their last bits (the QPs not solved leave no
    warm start); off: every step solved (before 2026-11-27; docs/safety.md)."""
    local_walls: bool = True
    """On a map's world (hundreds of wall boxes), whether the controller's rows and checks hold
    only the walls within reach of the robot (horizon plus braking distance, refreshed as it
    moves; docs/maps.md) rather than every wall; the same constraint verdicts, other worlds
    unaffected."""
    braking_tail: bool = True
    """Whether every accepted plan must end in a straight braking tail clear of the walls, and
    the robot follows the last accepted plan and its tail when no new plan is found
    (docs/safety.md); off: the earlier controller, which braked along its velocity (not in the paper)."""
    evasive_penalty: float = field(default=1e3, metadata=accepted(1.0, 1e9))
    """Cost of the evasive QP per metre of intrusion into another robot's required separation
    at the end of the horizon; an intrusion at ``tau`` costs ``T_MPC / tau`` times more. Far above
    the tracking cost's sensitivity (below about 10 per metre), so the penalty is exact: no
    intrusion that can be avoided is made."""
    evasive_curvature: float = field(default=1e3, metadata=accepted(1e-06, 1e9))
    """Quadratic cost of an intrusion (per m^2), which keeps the evasive QP strictly convex."""
    check_tolerance: float = field(default=1e-4, metadata=accepted(0.0, 0.1))
    """Violation of a constraint, checked exactly, that makes a solution unacceptable (m, m/s, m/s^2)."""
    contact_tolerance: float = field(default=1e-3, metadata=accepted(0.0, 0.1))
    """Penetration of the current state into a wall (the robot then brakes at once) or into another
    robot's predicted position (it then goes straight to the evasive plan) that counts as contact (m)."""
    fused_step: bool = True
    """Whether a step's set-up (predictions, requirements, warm start, first QP's rows and gradient)
    runs as one compiled call with its small matrix products as loops (default since the thirteenth
    round, docs/performance-15.md): fewer Python steps, sums agreeing with BLAS's to the last bits
    only (so trajectories differ there); off: BLAS's products, as before."""


@dataclass(frozen=True)
class ExecutionParams:
    """How a robot follows its selected joint plan between decisions (not in the paper)."""

    mode: Literal["gated", "timed"] = "gated"
    """``gated``: by the plan's precedences, waiting for the robots it depends on to move on
    (:mod:`nodnav.sim.execution`); ``timed``: by the clock, as the appendix."""
    lag: float = field(default=0.3, metadata=accepted(0.0, 10.0))
    """Least time between the two samples of a precedence (s); rules out waiting cycles between
    robots that pass each other closely."""
    tolerance: float = field(default=0.05, metadata=accepted(0.0, 1.0))
    """Distance within which an observed robot counts as still at the earliest of its nearest
    planned samples (m): how far it must move before it counts as having moved on."""
    reaction_margin: Literal["always", "moving", "surprised", "conflict", "off"] = "moving"
    """Towards which robots the MPC keeps clear of the braking trajectory by how far that can move
    in one control step (``nodnav.sim.execution.reaction_margin``): ``always`` every robot;
    ``moving`` (default) every robot that moves, that came at this one unexpectedly
    (``unexpected_approach``) within the last second, and every robot while this one cannot
    follow its plan; ``surprised`` the last two only; ``conflict`` the last only; ``off`` none."""
    mutual_braking: Literal["speed", "index", "strong", "stopping", "none"] = "speed"
    """Which check a robot's braking from its next step must pass towards each other robot
    (``nodnav.control.mutual_braking``, docs/safety.md). Of two robots that keep the rule, one
    takes the weak check (clear of the other's braking trajectory), the other the strong one (clear
    of wherever that trajectory can move in one step): ``speed`` (default) the faster one takes the
    weak check, the lower-numbered one at equal speeds; ``index`` the lower-numbered one; ``strong``
    both the strong one; ``stopping`` the one that needs longer to stop (``|v| / max_accel``),
    counting one that can stop within a control step as standing still, so that the role the
    opinion period gives two robots at rest holds while one starts (docs/mutual-braking-restart.md);
    ``none`` no check (before this setting; the paper has none). Towards a robot that does not
    keep the rule (another method, a person) there is no check."""
    restart_gap: bool = True
    """Whether a robot keeps, from every other robot that keeps the mutual braking rule, at least
    the gap from which either can start again under the strong check (``restart_gap`` in
    ``nodnav.control.mutual_braking``: ``1.5 a dt^2`` and the check's allowance, 0.031 m at
    2 m/s^2, plus 1e-4 m) where that exceeds ``controller.safety_margin``: robots that parked at
    the margin (0.02 m) knotted at a mouth and deadlocked (docs/safety.md). Off: the margin alone
    (before this setting); no effect with ``mutual_braking: none`` (the paper's)."""
    surprise: float = field(default=5e-3, metadata=accepted(0.0, 1.0, False))
    """How far another robot must come at this one beyond where its velocity would have taken it
    in one control step to count as unexpected, and how far it must move in a step to count as
    moving (m); half of what 2 m/s^2 gives in 0.1 s."""
    surprise_memory: float = field(default=1.0, metadata=accepted(0.0, 60.0))
    """For how long a robot that came at this one unexpectedly stays unexpected (s)."""
    reaction_slack: float = field(default=1e-3, metadata=accepted(0.0, 0.1))
    """How much of the present gap to another robot the reaction margin leaves free (m), so that
    switching the margin on never puts a robot inside the other's braking disc at once."""
    skip_at_rest: bool = True
    """Speed setting, on by default since the thirteenth round (it changes trajectories, by at most
    ``rest_tolerance``; off: as before, docs/performance-15.md): a robot at rest, whose reference
    stays where it stands and whom every prediction keeps ``rest_clearance`` beyond the full
    separation, stays exactly put without solving its MPC (docs/performance.md)."""
    rest_tolerance: float = field(default=1e-3, metadata=accepted(0.0, 0.1))
    """How far from its reference, and how fast, a robot may be to count as at rest (m, m/s)."""
    rest_clearance: float = field(default=0.5, metadata=accepted(0.0, 100.0))
    """How far beyond the full separation every other robot's predictions must stay for a robot
    at rest to skip its MPC (m)."""
    wait_patience: float = field(default=3.0, metadata=accepted(0.0, 600.0))
    """After how long (s) a robot held by its plan's precedences, while no robot of its plan got
    ``sim.progress_epsilon`` from where it was, stops waiting for those that hold it, for as long
    again (docs/execution.md, "Deadlocks in crowds"); 0: it waits for ever (before this setting)."""


@dataclass(frozen=True)
class BaselineParams:
    """Settings of the methods NOD is compared with (``nodnav run --method``); NOD reads none."""

    closest_first_tie: float = field(default=0.01, metadata=accepted(0.0, 10.0, False))
    """closest-first: distances to the entrance that round to the same multiple of this are a tie,
    which the lower robot number wins (m)."""
    orca_neighbor_dist: float = field(default=5.0, metadata=accepted(0.0, 1e3, False))
    """orca: centre distance within which other robots are taken into account (m)."""
    orca_time_horizon: float = field(default=2.0, metadata=accepted(0.0, 60.0, False))
    """orca: time for which velocities are kept safe with respect to other robots (s)."""
    orca_time_horizon_obst: float = field(default=1.0, metadata=accepted(0.0, 60.0, False))
    """orca: time for which velocities are kept safe with respect to walls (s)."""
    orca_radius_margin: float = field(default=0.02, metadata=accepted(0.0, 1.0))
    """orca: added to each robot's radius in RVO2, so contacts stay clear of the simulator's tolerance (m)."""
    orca_route_margin: float = field(default=0.05, metadata=accepted(0.0, 1.0))
    """orca: clearance beyond the radius kept by the route the preferred velocity follows (m);
    larger than ``orca_radius_margin`` so that the preferred velocity does not press against a wall."""


@dataclass(frozen=True)
class SimParams:
    """How a trial is simulated and judged."""

    goal_tolerance: float = field(default=0.15, metadata=accepted(0.0, 1.0, False))
    """A robot has arrived when it is this close to its destination (m)."""
    collision_tolerance: float = field(default=1e-3, metadata=accepted(0.0, 0.1))
    """Penetration beyond which a contact counts as a collision (m)."""
    deadlock_time: float = field(default=10.0, metadata=accepted(0.0, 3600.0, False))
    """A trial is a deadlock when no robot has progressed for this long (s)."""
    progress_epsilon: float = field(default=0.2, metadata=accepted(0.0, 10.0))
    """Decrease of a robot's distance-to-go below its best so far that counts as progress (m); a
    robot radius, so that robots creeping a few centimetres at a time in a jam do not count."""
    observation_noise: float = field(default=0.0, metadata=accepted(0.0, 1.0))
    """Standard deviation of the position noise in what each robot observes of the others (m)."""
    progress: Literal["plan", "straight"] = "plan"
    """What counts as progress for ``deadlock_time``: ``straight``, the distance to go through the
    mouths falling by ``progress_epsilon`` (before issue 19); ``plan`` (default), that or advancing
    ``progress_epsilon`` along the successful plan the robot follows, e.g. backing out of the
    passage for another robot (:mod:`nodnav.sim.progress`)."""


@dataclass(frozen=True)
class SensingParams:
    """What each robot can see of the others (docs/sensing.md); the defaults are the paper's:
    every robot sees every other one, through walls and at any distance."""

    range: float = field(default=0.0, metadata=accepted(0.0, MAX_WORLD_SIZE))
    """Sensor range: another robot is seen while its centre is within this distance (m); 0 means
    unlimited; paper: unlimited (0)."""
    walls_block: bool = False
    """Whether walls and obstacles block the line of sight between two robots' centres; paper: false."""
    memory: float = field(default=3.0, metadata=accepted(0.0, 3600.0))
    """How long a robot remembers another it no longer sees, held still where last seen (s); paper:
    unused (everyone is always seen)."""
    uncertainty_rate: float = field(default=0.5, metadata=accepted(0.0, 10.0))
    """Growth of the uncertainty radius kept around a remembered robot, per second since it was
    last seen (m/s); paper: unused."""

    stop_within_sight: bool = True
    """With a range: each robot drives no faster than it can stop within half of what it sees
    (:func:`nodnav.sim.sensing.sight_speeds`), so two robots that meet head-on as they come into
    range stop apart; paper: unused (unlimited range)."""
    occlusion_speed: bool = True
    """With limited sight: each robot drives no faster than it can stop within half of the distance
    to the nearest place it cannot see where another robot could stand
    (:class:`nodnav.sim.sensing.OcclusionLimit`); false: no such limit (before); paper: unused."""
    drop_probability: float = field(default=0.0, metadata=accepted(0.0, 0.99))
    """Probability that an observation of another robot is lost at a control step (independent per
    observer, robot and step); paper: 0."""
    filter: Literal["kalman", "none"] = "kalman"
    """How the others' states are estimated from noisy observations: ``kalman`` (a constant-velocity
    Kalman filter per observer and robot, only when there is noise or loss) or ``none`` (the raw
    observation, the behaviour before the filter); paper: exact observations, no filter runs."""
    margin_sigmas: float = field(default=2.0, metadata=accepted(0.0, 10.0))
    """Separation the MPC adds to another robot's radius, in standard deviations of the filter's
    position estimate of it (dimensionless); paper: unused (exact observations)."""

    @property
    def limited(self) -> bool:
        """Whether sight is limited at all (otherwise the paper's: everyone sees everyone)."""
        return self.range > 0.0 or self.walls_block
