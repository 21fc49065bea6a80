"""What several test modules share: a stand-in for a trial's result, for tests of what is done
with results (sweeps, the results database, reports) rather than of the trials themselves."""

import importlib.util
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import cloudpickle
import pytest
from hypothesis import settings

# Property tests draw the same examples on every run (derandomize: each test's draws are seeded
# from the test itself), so a failure in CI fails again on any machine; HYPOTHESIS_PROFILE=explore
# draws fresh examples each run, to look for new counterexamples on purpose. No example database:
# a clean clone and a developer's checkout run the same examples.
settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False, database=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

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


@pytest.fixture(scope="session")
def tool_script():
    """The loader of a script of tools/ (not a package) as a module: ``tool_script("paired_outcomes")``."""
    tools = Path(__file__).resolve().parents[1] / "tools"

    def load(name: str):
        spec = importlib.util.spec_from_file_location(name, tools / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    return load
