"""Whether a drawn scenario is valid and solvable in principle: the one check draws pass.

Validity and room capacity (:func:`~nodnav.scenario.validity.check_layout`,
:func:`~nodnav.scenario.validity.check_capacity`), then the serial witness
(:func:`~nodnav.scenario.validity.find_witness`) and, where robots inside the passage head opposite
ways and no serial schedule exists, the witness after one side backs out or ducks into a bay
(:func:`~nodnav.scenario.backing_out.find_witness_backing_out`). The module docstring of
:mod:`nodnav.scenario.validity` states the rules.
"""

from __future__ import annotations

from nodnav.scenario.backing_out import find_witness_backing_out
from nodnav.scenario.schema import Scenario
from nodnav.scenario.validity import WITNESS_BUDGET, Verdict, check_capacity, check_layout, find_witness


def check_scenario(scenario: Scenario, budget: int = WITNESS_BUDGET) -> Verdict:
    """Validity, room capacity and solvability (the module docstring), the first failure's reason."""
    for check in (check_layout, check_capacity):
        verdict = check(scenario)
        if not verdict.ok:
            return verdict
    verdict = find_witness(scenario, budget)
    if not verdict.ok:  # robots inside heading opposite ways: one side may back out (issue 19)
        backing = find_witness_backing_out(scenario, budget)
        if backing.ok:
            return backing
    return verdict
