"""Drawing scenarios from a family: deterministic, valid and solvable by construction.

:func:`draw` builds one scenario step by step (robots and their radii and speeds, a single-file
corridor for them, rooms, start formations, robots inside the corridor, destinations), keeping
:data:`~nodnav.scenario.layout.SLACK` beyond every rule of :mod:`nodnav.scenario.validity`, then checks the result with
:func:`~nodnav.scenario.solvable.check_scenario`: validity, room capacity and the witness of
solvability. A drawn scenario is named ``FAMILY:SEED``; ``nodnav run mixed:17`` (or ``path/fam.yaml:17``)
loads it wherever a scenario name is accepted. Its ``time_limit`` is
``ceil(20 + 1.5 (max_i t_i(l_i) + sum_i t_i(L + 4 r_max)))`` seconds, with ``l_i`` robot i's
route through the entrances, ``L`` the corridor's length and ``t_i(l)`` the least time robot i
needs to cover ``l`` from rest to rest at its speed limit and half its acceleration limit
(:func:`~nodnav.scenario.layout.travel_time`): the slowest robot's own route plus every robot crossing in turn, each
holding the corridor for its length and two diameters, with 50 % slack and 20 s to decide.

Determinism: draws use their own :class:`numpy.random.Generator` seeded by
``SeedSequence(seed, spawn_key=(DRAW_STREAM,))``, a stream no trial generator
(:func:`nodnav.sim.simulator.trial_generators`, children 0..2 N_r - 1 of ``SeedSequence(seed)``)
shares; only ``random()`` is called, with plain arithmetic and one square root, and every
coordinate is rounded to the millimetre, so a scenario written to YAML reads back identical.
A draw that breaks a rule is redrawn from the same stream, at most :data:`MAX_ATTEMPTS` times.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import yaml

from nodnav.scenario.building_family import BuildingFamily
from nodnav.scenario.families import Family, FamilyError, load_family, parse_draw_spec
from nodnav.scenario.layout import _Attempt, _Draws, _Reject
from nodnav.scenario.meeting import attempt_for
from nodnav.scenario.schema import Scenario, scenario_from_dict, scenario_to_dict
from nodnav.scenario.solvable import check_scenario

DRAW_STREAM = 0x46414D49
"""Spawn key of the draws' seed sequence ('FAMI'), far from the trial generators' 0..2 N_r - 1."""
MAX_ATTEMPTS = 200
"""Redraws allowed before a draw gives up with an error."""
def draw_spec(spec: str) -> Scenario | None:
    """The scenario ``FAMILY:SEED`` names, or ``None`` if ``spec`` is not of that form."""
    parsed = parse_draw_spec(spec)
    if parsed is None:
        return None
    return draw(load_family(parsed[0]), parsed[1])


def draw_generator(seed: int) -> np.random.Generator:
    """The generator of draw ``seed``: its own stream, apart from every trial generator of the same seed."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(DRAW_STREAM,)))


def _attempt(family: Family, d: _Draws) -> _Attempt:
    """One attempt: the plain construction, or robots meeting inside and bays (issue 19)."""
    return attempt_for(family, d)


def _check_seed(seed) -> None:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**63:
        raise FamilyError(f"seed: expected a whole number in 0 .. 2^63 - 1, got {seed!r}")


def draw_building(family: BuildingFamily, seed: int, attempts: int = MAX_ATTEMPTS) -> dict:
    """The scenario mapping of draw ``seed`` of a floor-plan family, valid and solvable
    (:func:`~nodnav.scenario.building_check.check_building`), with every passage in
    ``world.passages`` (or a :class:`FamilyError`)."""
    from nodnav.scenario.building import BuildingAttempt
    from nodnav.scenario.building_check import check_building

    _check_seed(seed)
    d = _Draws(draw_generator(int(seed)))
    reasons: dict[str, int] = {}
    for _ in range(attempts):
        try:
            mapping = BuildingAttempt(family, d).draw(int(seed))
        except _Reject as exc:
            reasons[str(exc)] = reasons.get(str(exc), 0) + 1
            continue
        verdict = check_building(mapping)
        if verdict.ok:
            return mapping
        kind = re.sub(r"[0-9][0-9.]*", "N", verdict.reason)
        reasons[kind] = reasons.get(kind, 0) + 1
    common = max(reasons, key=lambda reason: reasons[reason]) if reasons else "-"
    raise FamilyError(f"{family.name}:{seed}: no valid floor plan in {attempts} attempts (most often: {common}); "
                      "widen the family's rooms or ranges")


def draw(family: Family | BuildingFamily, seed: int, attempts: int = MAX_ATTEMPTS) -> Scenario:
    """Scenario ``seed`` of ``family``: deterministic, valid and solvable (or a :class:`FamilyError`)."""
    if isinstance(family, BuildingFamily):
        mapping = draw_building(family, seed, attempts)
        return scenario_from_dict(mapping, mapping["name"])
    _check_seed(seed)
    d = _Draws(draw_generator(int(seed)))
    reasons: dict[str, int] = {}
    for _ in range(attempts):
        try:
            mapping = _attempt(family, d).draw(int(seed))
        except _Reject as exc:
            reasons[str(exc)] = reasons.get(str(exc), 0) + 1
            continue
        scenario = scenario_from_dict(mapping, mapping["name"])
        verdict = check_scenario(scenario)
        if verdict.ok:
            return scenario
        kind = re.sub(r"[0-9][0-9.]*", "N", verdict.reason)  # group reasons that differ only in numbers
        reasons[kind] = reasons.get(kind, 0) + 1
    common = max(reasons, key=lambda reason: reasons[reason]) if reasons else "-"
    raise FamilyError(f"{family.name}:{seed}: no valid scenario in {attempts} attempts (most often: {common}); "
                      "widen the family's rooms or ranges, or set rooms.grow: true")


def write_draws(family: Family | BuildingFamily, seed: int, count: int, out: str | Path) -> list[Path]:
    """Write draws ``seed .. seed + count - 1`` of ``family`` as scenario files ``out/NAME-SEED.yaml``.

    Each file is :func:`~nodnav.scenario.schema.scenario_to_dict` of the draw; loading it gives the
    same scenario, and ``nodnav run FILE`` runs it like ``nodnav run NAME:SEED``.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise FamilyError(f"--out: {out} is a file; give a directory for the scenario files")
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise FamilyError(f"--count: expected a whole number >= 1, got {count!r}")
    written = []
    for s in range(seed, seed + count):
        path = out / f"{family.name}-{s}.yaml"
        text = yaml.safe_dump(scenario_to_dict(draw(family, s)), sort_keys=False)
        try:
            out.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        except OSError as exc:
            raise FamilyError(f"--out: cannot write {path} ({exc.strerror or exc})") from None
        written.append(path)
    return written
