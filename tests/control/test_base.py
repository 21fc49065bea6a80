"""``ControlRequest.built`` against the constructor: the same request, field for field."""

from dataclasses import fields

import numpy as np

from nodnav.control.base import ControlRequest, ControlResult


def test_a_request_built_has_the_constructors_fields():
    args = [np.zeros(2), np.ones(2), np.zeros((8, 2)), np.arange(1.0, 9.0), np.zeros((3, 8, 2)), np.full(3, 0.3),
            np.array([False, False, True]), None, np.full(3, 0.1)]
    built, want = ControlRequest.built(*args), ControlRequest(*args)
    assert type(built) is ControlRequest
    assert all(getattr(built, f.name) is getattr(want, f.name) for f in fields(ControlRequest))
    assert ControlRequest.built(*args[:6]).margins is None and ControlRequest.built(*args[:6]).firm is None


def test_a_result_built_has_the_constructors_fields():
    args = [False, "why", np.ones(2), np.zeros(2), np.full(2, 0.5), np.zeros((8, 2)), 0.25, np.zeros((4, 2)),
            {"fallback": "braking"}]
    names = ("success", "reason", "velocity", "next_position", "next_velocity", "planned_positions", "solve_time",
             "step_positions", "info")
    built, want = ControlResult.built(*args), ControlResult(**dict(zip(names, args)))
    assert type(built) is ControlResult and built == want
    assert all(getattr(built, f.name) is getattr(want, f.name) for f in fields(ControlResult))
