"""The rotation check of issue 20: a scenario turned and moved as a whole must play out the same.

A trial of a scenario and of the scenario turned by ``angle`` and moved by ``shift``
(:func:`~nodnav.scenario.transform.transform_scenario`) are compared: outcome, entry order, and
the trajectories turned back. The closed loop is chaotic (rounding differences of 1e-16 m grow,
and NOD amplifies them on purpose where a scenario is symmetric: that is how it breaks a tie), so
the comparison is stated as

* the same outcome;
* the same entry order, or the same but for robots that are mirror images of each other (under
  a reflection of the passage's frame that maps the scenario's robots onto one another) swapping
  places: the built-ins are placed by hand, symmetric, with robots equally far from their
  entrance; such a tie is broken by rounding, and either way round is equally right;
* the trajectories turned back (a swapped robot compared with its stand-in's mirror image): the
  time up to which they agree within ``1e-6`` m, the largest and the mean distance over the
  trial, and the difference of the makespans.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from nodnav.scenario.schema import Scenario
from nodnav.scenario.transform import transform_scenario, untransform_points
from nodnav.sim.simulator import run_trial

#: Distance (m) under which two trajectories count as the same trajectory.
SAME = 1e-6


@dataclass(frozen=True)
class RotationComparison:
    """How a trial and the same trial turned compare."""

    name: str
    """Scenario name."""
    angle: float
    """Angle (degrees)."""
    outcomes: tuple[str, str]
    """Outcome of the trial and of the turned trial."""
    entry_orders: tuple[tuple[int, ...], tuple[int, ...]]
    """Entry orders (robots 0-based)."""
    order_match: str
    """``same``, ``symmetric`` (the same but for robots that are mirror images of each other
    swapping places) or ``different``."""
    same_until: float
    """Time (s) up to which the trajectories agree within :data:`SAME` (the whole trial when they always do)."""
    max_distance: float
    """Largest distance (m) between a robot and its counterpart turned back, over the common samples."""
    mean_distance: float
    """Mean distance (m) between a robot and its counterpart turned back, over robots and common samples."""
    makespan_difference: float
    """Difference of the makespans (s); NaN unless both succeeded."""

    @property
    def agrees(self) -> bool:
        """Same outcome and the same entry order (up to the scenario's mirror symmetry)."""
        return self.outcomes[0] == self.outcomes[1] and self.order_match != "different"


def mirror_permutations(scenario: Scenario) -> list[tuple[np.ndarray, np.ndarray]]:
    """The reflections of the passage's frame that map the scenario's robots onto one another:
    ``(matrix, permutation)`` with ``matrix`` the linear part about the passage's centre and
    ``permutation[i]`` the robot that robot ``i``'s image is. Robots must match in every
    setting but their places; the walls are assumed symmetric too (the built-ins' are)."""
    g = scenario.world.passage
    u, n = np.asarray(g.axis), np.asarray(g.normal)
    centre = 0.5 * (np.asarray(g.start) + np.asarray(g.end))
    reflections = [np.outer(u, u) - np.outer(n, n), np.outer(n, n) - np.outer(u, u), -np.eye(2)]
    specs = [dataclasses.replace(r, origin=(0.0, 0.0), destination=(0.0, 0.0)) for r in scenario.robots]
    ends = np.stack([scenario.origins, scenario.destinations], axis=1)  # (N, 2, 2)
    out = []
    for m in reflections:
        image = (ends - centre) @ m.T + centre
        perm = np.full(len(ends), -1)
        for i in range(len(ends)):
            match = np.flatnonzero(np.all(np.abs(ends - image[i]) < 1e-9, axis=(1, 2)))
            if len(match) == 1 and specs[int(match[0])] == specs[i]:
                perm[i] = int(match[0])
        bijective = (perm >= 0).all() and len(set(perm.tolist())) == len(perm)
        if bijective and not np.array_equal(perm, np.arange(len(perm))):
            out.append((m, perm))
    return out


def compare_rotated(scenario: Scenario, angle: float, shift=(0.0, 0.0), seed: int = 1,
                    method: str = "nod") -> RotationComparison:
    """Run ``scenario`` and its turned and moved copy with the same seed and compare them."""
    a = run_trial(scenario, method=method, seed=seed)
    b = run_trial(transform_scenario(scenario, angle, shift), method=method, seed=seed)
    pb = untransform_points(np.asarray(b.history.arrays()["positions"]), angle, shift)
    return _compare(scenario, float(angle), a, b, pb)


def compare_perturbed(scenario: Scenario, eps: float, seed: int = 1, method: str = "nod") -> RotationComparison:
    """The same comparison between ``scenario`` and ``scenario`` with every origin moved by
    ``(eps, -eps)`` (m), unturned: how far rounding-sized differences alone carry a trial
    (the ``angle`` of the result is NaN)."""
    robots = tuple(dataclasses.replace(r, origin=(r.origin[0] + eps, r.origin[1] - eps)) for r in scenario.robots)
    a = run_trial(scenario, method=method, seed=seed)
    b = run_trial(dataclasses.replace(scenario, robots=robots), method=method, seed=seed)
    return _compare(scenario, float("nan"), a, b, np.asarray(b.history.arrays()["positions"]))


def _compare(scenario: Scenario, angle: float, a, b, pb: np.ndarray) -> RotationComparison:
    """Compare trial ``a`` with trial ``b`` whose positions, mapped back, are ``pb``."""
    pa = np.asarray(a.history.arrays()["positions"])
    order_a, order_b = tuple(a.entry_order), tuple(b.entry_order)
    match = "same" if order_a == order_b else "different"
    mirrors = mirror_permutations(scenario)
    if match == "different" and len(order_a) == len(order_b):
        # Robots that are mirror images of each other may swap places in the order: the tie
        # between them is broken by rounding. Compare each with its stand-in's mirror image.
        g = scenario.world.passage
        centre = 0.5 * (np.asarray(g.start) + np.asarray(g.end))
        mapped = pb.copy()
        ok = True
        for i, j in zip(order_a, order_b):
            if i == j:
                continue
            m = next((m for m, perm in mirrors if perm[i] == j), None)
            if m is None:
                ok = False
                break
            mapped[:, i] = (pb[:, j] - centre) @ m.T + centre
        if ok:
            match, pb = "symmetric", mapped
    k = min(len(pa), len(pb))
    apart_by = np.linalg.norm(pa[:k] - pb[:k], axis=-1)
    dist = apart_by.max(axis=1)
    times = np.asarray(a.history.arrays()["times"])[:k]
    apart = np.flatnonzero(dist > SAME)
    if len(apart):
        same_until = float(times[apart[0] - 1]) if apart[0] > 0 else 0.0
    else:
        same_until = float(times[-1])
    makespan = float(b.makespan - a.makespan) if a.outcome == b.outcome == "success" else float("nan")
    return RotationComparison(scenario.name, float(angle), (a.outcome, b.outcome), (order_a, order_b), match,
                              same_until, float(dist.max()), float(apart_by.mean()), makespan)
