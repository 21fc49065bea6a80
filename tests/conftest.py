"""What several test modules share: a stand-in for a trial's result, for tests of what is done
with results (sweeps, the results database, reports) rather than of the trials themselves."""

import sys
from dataclasses import dataclass, field

import cloudpickle
import pytest

# A sweep with several workers sends its trial function to other processes, which cannot import
# this file: what it defines goes by value.
cloudpickle.register_pickle_by_value(sys.modules[__name__])


@dataclass
class FakeTrialResult:
    """Quacks like :class:`~nodnav.sim.trial_result.TrialResult` for whatever stores or reports it:
    ``outcome``, ``metrics`` and ``to_dict()``, the summary with the outcome and the metrics, as
    the real one gives."""

    outcome: str
    """``success``, ``deadlock``, ..."""
    summary: dict = field(default_factory=dict)
    """The rest of what ``to_dict()`` gives (seed, times, strategy, ...)."""
    metrics: dict = field(default_factory=dict)
    """The trial's metrics."""

    def to_dict(self) -> dict:
        return {"outcome": self.outcome, **self.summary, **self.metrics}


@pytest.fixture
def trial_result():
    """The factory of stand-in trial results: ``trial_result(outcome, summary, metrics)``
    (:class:`FakeTrialResult`), for a stand-in trial function ``(scenario, method, seed) -> result``."""
    return FakeTrialResult
