"""The closed loop: robots' decisions, their motion, and how a trial is judged.

Importing this package registers the built-in navigation methods (:data:`~nodnav.registry.METHODS`):
``nod`` (:mod:`nodnav.sim.methods`), the baselines (:mod:`nodnav.sim.baselines`) and the people
(:mod:`nodnav.sim.person`).
"""

from nodnav.registry import METHODS
from nodnav.sim import baselines, methods, person

__all__ = ["METHODS", "baselines", "methods", "person"]
