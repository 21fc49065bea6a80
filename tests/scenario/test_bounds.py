"""Bounds declared once: every number of a scenario declares its range on its field, loading refuses
a value just outside it with the one line that range gives, and the reference page is what the
code declares."""

import dataclasses
import inspect
import typing
from pathlib import Path

import pytest

from nodnav.scenario import params
from nodnav.scenario.bounds import SECTIONS, declared_bounds, reference_page
from nodnav.scenario.fields import ScenarioError, field_range
from nodnav.scenario.limits import range_text
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import scenario_from_dict, scenario_to_dict

ROOT = Path(__file__).resolve().parents[2]
NUMBERS = (float, int, tuple[float, ...], dict[str, float], tuple[tuple[float, ...], ...])


def test_the_reference_page_is_what_the_code_declares():
    page = (ROOT / "docs" / "reference-bounds.md").read_text()
    assert page == reference_page(), "docs/reference-bounds.md is stale: run tools/reference_bounds.py"


def test_every_parameter_class_is_in_a_section():
    listed = {cls for _, classes in SECTIONS for cls, _ in classes}
    declared = {obj for _, obj in inspect.getmembers(params, inspect.isclass)
                if dataclasses.is_dataclass(obj) and obj.__module__ == params.__name__}
    assert declared <= listed


@pytest.mark.parametrize("cls", sorted({cls for _, classes in SECTIONS for cls, _ in classes},
                                       key=lambda c: c.__name__))
def test_every_number_declares_its_range(cls):
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if hints[f.name] in NUMBERS:
            bound = field_range(f)
            assert bound is not None, f"{cls.__name__}.{f.name} declares no range"
            low, high, _ = bound
            assert low < high, f"{cls.__name__}.{f.name}"


def _written(key, value, hint):
    """Where ``value`` goes in a scenario mapping for ``key``, and the key path the error names."""
    if hint == tuple[float, ...]:
        return [value], f"{key}[0]"
    if hint == dict[str, float]:
        return {"S1": value}, f"{key}.S1"
    if hint == tuple[tuple[float, ...], ...]:
        return [[value]], f"{key}[0][0]"
    return value, key


CASES = [(b, side) for b in declared_bounds() for side in ("below", "above")]


@pytest.mark.parametrize("bound, side", CASES, ids=[f"{b.key}-{side}" for b, side in CASES])
def test_a_value_just_outside_a_declared_range_is_refused_in_one_line(bound, side):
    section, _, name = bound.key.rpartition(".")
    cls = next(c for s, classes in SECTIONS if s == section for c, owner in classes if owner == bound.owner
               and name in {f.name for f in dataclasses.fields(c)})
    hint = typing.get_type_hints(cls)[name]
    low, high, closed = bound.bound
    if side == "below":
        value = (int(low) - 1 if hint is int else low - max(abs(low), 1.0) * 1e-3) if closed else low
    else:
        value = int(high) + 1 if hint is int else high + max(abs(high), 1.0) * 1e-3
    raw = scenario_to_dict(load_scenario("2r-case1"))
    written, where = _written(bound.key, value, hint)
    if section == "robots":
        raw["robot_defaults"] = {name: written}
        for robot in raw["robots"]:
            robot.pop(name)
        where = where.replace("robots.", "robot_defaults.")
    elif section:
        raw[section] = {**raw.get(section, {}), name: written}  # sensing is absent when it is the paper's
        if bound.owner:
            raw[section] = {"name": bound.owner, name: written}
    else:
        raw[name] = written
    with pytest.raises(ScenarioError) as error:
        scenario_from_dict(raw)
    assert str(error.value) == f"{where}: must be {range_text(bound.bound)}, got {value!r}"
