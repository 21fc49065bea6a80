"""A planner of your own, registered under a name that scenario files can use.

It plans with the built-in fast planner as if every robot were slower than it is (by
``speed_factor``), which leaves the controller speed in hand to catch up after a delay. Importing
this file registers it as ``cautious``; ``cautious_scenario.yaml`` names it.
"""

from dataclasses import dataclass, field, replace

import nodnav
from nodnav.planning import make_planner


@dataclass(frozen=True)
class CautiousParams(nodnav.PlannerParams):
    """The cautious planner's settings: the shared ones (name, dt, margin) and its own."""

    speed_factor: float = field(default=0.8, metadata={"range": (0.1, 1.0, True)})
    """Fraction of each robot's speed limit the plans use."""


@nodnav.register_planner("cautious", params=CautiousParams)
class CautiousPlanner:
    """The fast planner at a fraction of the speed limits."""

    def __init__(self, world: nodnav.World, params: CautiousParams):
        self.params = params
        self.fast = make_planner(nodnav.FastPlannerParams(dt=params.dt, margin=params.margin), world)

    def plan(self, request: nodnav.PlanRequest) -> nodnav.PlanResult:
        return self.fast.plan(replace(request, max_speeds=request.max_speeds * self.params.speed_factor))
