"""What a scenario may ask for: the size limits, and how a number's accepted range is declared.

A scenario outside these bounds is refused when it is loaded (:mod:`nodnav.scenario.schema`),
with one line naming the key and the bound, so that nothing downstream can be asked for
something it cannot do: a control step so small that the clock overflows, an acceleration so
small that the controller divides by nearly zero, a horizon that needs terabytes, more passing
orders than memory holds. The size limits are here; the range of every number is declared on
its parameter field (:func:`accepted`, in :mod:`nodnav.scenario.params`), as a plugin's are, and
``docs/reference-bounds.md`` is generated from both (:mod:`nodnav.scenario.bounds`). The values
were chosen from what the code does with each number (see each docstring and reason), not from
taste: the paper's values and the built-in scenarios sit well inside every range.
"""

from __future__ import annotations

import math
from typing import Any

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


def accepted(low: float, high: float, low_included: bool = True, why: str = "") -> dict[str, Any]:
    """A parameter field's ``metadata`` declaring its accepted range: ``field(default=1.0,
    metadata=accepted(0.0, 2.0, False, why="..."))`` is ``metadata={"range": (0.0, 2.0, False)}``
    with the reason for the bound, which the bounds table shows (:mod:`nodnav.scenario.bounds`).

    Every number a scenario may hold declares its range so, on the field of its parameter
    dataclass; a list's or a mapping's range applies to each of its numbers.
    """
    return {"range": (low, high, low_included), **({"why": why} if why else {})}


def range_text(bound: Range) -> str:
    """A range in words, e.g. ``from 0.01 to 1`` or ``above 0 and at most 2``."""
    low, high, closed = bound
    return f"from {low:g} to {high:g}" if closed else f"above {low:g} and at most {high:g}"


def in_range(bound: Range, value: float) -> bool:
    """Whether ``value`` lies in the range."""
    low, high, closed = bound
    return (value >= low if closed else value > low) and value <= high
