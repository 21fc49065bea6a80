"""What a scenario may ask for: the accepted range of every number and the size limits.

A scenario outside these bounds is refused when it is loaded (:mod:`nodnav.scenario.schema`),
with one line naming the key and the bound, so that nothing downstream can be asked for
something it cannot do: a control step so small that the clock overflows, an acceleration so
small that the controller divides by nearly zero, a horizon that needs terabytes, more passing
orders than memory holds. The README lists the same bounds; the values were chosen from what
the code does with each number (see each docstring), not from taste: the paper's values and
the built-in scenarios sit well inside every range.
"""

from __future__ import annotations

import math

MAX_STRATEGIES = 720
"""Most passing orders a robot may weigh at once: the ``(k+1)!`` orders of its game, itself and
its ``k`` game players (:mod:`nodnav.decision.games`), so games of at most 6 robots.

Every decision, a robot plans, estimates (4) and updates (8) once per order of its game: with all
players that is ``N_r!``, and 7 robots (5,040 orders) took about ten seconds of computing per
simulated second when the bound was chosen; 720 orders are about a second. With game players
(``game_players: k``) the number of robots is bounded only by :data:`MAX_ROBOTS`.
"""

MAX_GAME = max(n for n in range(1, 21) if math.factorial(n) <= MAX_STRATEGIES)
"""Most robots in one robot's game (itself and its game players), implied by :data:`MAX_STRATEGIES`."""

MAX_ROBOTS = 10
"""Most robots a scenario may have. With ``k`` game players a decision costs ``(k+1)!`` plans
and grows linearly in ``N_r`` (``nodnav bench scaling``); the history, a few kilobytes per
control step, and trial length grow with it."""

MAX_CONTROL_STEPS = 100_000
"""Most control steps of a trial, ``time_limit / controller.dt``: the history keeps every
step's state (a few kilobytes each with four robots)."""

MAX_PLAN_STEPS = 10_000
"""Most time steps a planned path may need to cross the world, ``diagonal of world.bounds /
(slowest max_speed x planner.dt)``: the fast planner's occupancy tables grow with its square
(30,000 steps took about 1 GB when the bound was chosen)."""

MAX_WORLD_SIZE = 100.0
"""Longest side of ``world.bounds`` (m)."""

MAX_COORDINATE = 1000.0
"""Largest absolute value of any coordinate (m)."""

MAX_OBSTACLES = 100
"""Most wall rectangles in ``world.obstacles``."""

MAX_NAME = 100
"""Longest scenario ``name`` (characters; one line of printable text)."""

MAX_DESCRIPTION = 1000
"""Longest scenario ``description`` (characters)."""

MAX_FILE_BYTES = 1 << 20
"""Largest scenario or study file read (bytes): 1 MiB, a thousand times a built-in scenario."""

MAX_LIST = 100
"""Longest list of numbers a parameter may hold (e.g. ``planner.retreat_radii``)."""

Range = tuple[float, float, bool]
"""An accepted range ``(least, greatest, least_included)``; the greatest is always included."""

#: Accepted range of every number of a scenario, by key (``robots`` keys apply to
#: ``robot_defaults`` and to every robot alike; a list's range applies to each of its numbers).
RANGES: dict[str, Range] = {
    # The opinion layer. The discrete update (8) multiplies z by (1 - alpha d) with alpha(0) = 1:
    # d above 2 makes it diverge; u, b, z0 far above the paper's values only overflow.
    "opinion.u": (0.0, 1e4, True),
    "opinion.d": (0.0, 2.0, False),
    "opinion.eta": (1e-3, 1e3, True),
    "opinion.K1": (0.0, 1e3, True),
    "opinion.T": (0.0, 60.0, False),
    "opinion.alpha_min": (0.0, 1.0, False),
    "opinion.K2": (0.0, 1e3, True),
    "opinion.delta": (1e-3, 1e3, True),
    "opinion.bias": (-1e6, 1e6, True),
    "opinion.z0": (-1e6, 1e6, True),
    "opinion.standoff_patience": (0.0, 600.0, True),
    # Robots. Every accepted speed and acceleration is safe (docs/safety.md): the controller
    # keeps a braking tail clear of the walls whatever they are. Below 0.1 m/s^2 a robot needs
    # tens of metres to stop from ordinary speeds, so it crawls; above 5 m/s it crosses the
    # corridor in a few control steps.
    "robots.radius": (0.01, 5.0, True),
    "robots.max_speed": (0.05, 5.0, True),
    "robots.max_accel": (0.1, 50.0, True),
    # The planner.
    "planner.dt": (0.01, 1.0, True),
    "planner.margin": (0.0, 0.5, True),
    "planner.door_clearance": (0.0, 10.0, True),
    "planner.clearing_radii": (0.01, MAX_WORLD_SIZE, True),
    "planner.clearing_directions": (1, 360, True),
    "planner.w1": (0.0, 1e3, True),
    "planner.varsigma": (0.0, 1.0, True),
    "planner.roadmap_vertices": (10, 10_000, True),
    "planner.connect_factor": (1, 100, True),
    "planner.link_widening": (1, 100, True),
    # The fast planner's ways of making room: spots up to a world's side away, in rings of a few
    # dozen directions; each try and each level of the cascade replans robots, so both stay small.
    "planner.retreat_radii": (0.01, MAX_WORLD_SIZE, True),
    "planner.retreat_angles": (1, 360, True),
    "planner.retreat_tries": (1, 100, True),
    "planner.cascade": (0, 6, True),
    # The controller: the MPC needs dt <= horizon; its constraint grid has horizon / 0.05 s pieces.
    "controller.dt": (0.01, 1.0, True),
    "controller.horizon": (0.01, 5.0, True),
    "controller.w2": (0.0, 1e3, True),
    "controller.safety_margin": (0.0, 0.5, True),
    "controller.samples": (1, 100, True),
    # The MPC's numerical settings: its QP has 2 (segments + 3) - 4 variables and rows for every
    # interval of at least max_interval over the horizon, every polygon side and terminal piece.
    "controller.segments": (2, 64, True),
    "controller.max_interval": (0.01, 1.0, True),
    "controller.speed_polygon_sides": (4, 64, True),
    "controller.accel_polygon_sides": (4, 64, True),
    "controller.terminal_pieces": (1, 32, True),
    "controller.terminal_decel": (0.0, 1.0, False),
    "controller.sqp_iterations": (1, 10, True),
    "controller.sqp_tolerance": (0.0, 1.0, True),
    "controller.qp_tolerance": (1e-12, 1e-3, True),
    "controller.evasive_penalty": (1.0, 1e9, True),
    "controller.evasive_curvature": (1e-6, 1e9, True),
    "controller.check_tolerance": (0.0, 0.1, True),
    "controller.contact_tolerance": (0.0, 0.1, True),
    # The simulation.
    "sim.goal_tolerance": (0.0, 1.0, False),
    "sim.collision_tolerance": (0.0, 0.1, True),
    "sim.deadlock_time": (0.0, 3600.0, False),
    "sim.progress_epsilon": (0.0, 10.0, True),
    "sim.observation_noise": (0.0, 1.0, True),
    # Execution: precedences reach back a lag of at least one control step when it is positive.
    "execution.lag": (0.0, 10.0, True),
    "execution.tolerance": (0.0, 1.0, True),
    "execution.surprise": (0.0, 1.0, False),
    "execution.surprise_memory": (0.0, 60.0, True),
    "execution.reaction_slack": (0.0, 0.1, True),
    # The baselines.
    "baselines.closest_first_tie": (0.0, 10.0, False),
    "baselines.orca_neighbor_dist": (0.0, 1e3, False),
    "baselines.orca_time_horizon": (0.0, 60.0, False),
    "baselines.orca_time_horizon_obst": (0.0, 60.0, False),
    "baselines.orca_radius_margin": (0.0, 1.0, True),
    "baselines.orca_route_margin": (0.0, 1.0, True),
    "time_limit": (0.0, 3600.0, False),
}


def range_text(key: str | Range) -> str:
    """The range of ``key`` (or a range) in words, e.g. ``from 0.01 to 1`` or ``above 0 and at most 2``."""
    low, high, closed = RANGES[key] if isinstance(key, str) else key
    return f"from {low:g} to {high:g}" if closed else f"above {low:g} and at most {high:g}"


def in_range(key: str | Range, value: float) -> bool:
    """Whether ``value`` lies in the range of ``key`` (or in a range)."""
    low, high, closed = RANGES[key] if isinstance(key, str) else key
    return (value >= low if closed else value > low) and value <= high
