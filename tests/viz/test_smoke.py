"""Every figure module draws without error on the Agg backend and writes a picture of the size asked."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.image import imread  # noqa: E402

from nodnav.planning import PlanRequest, make_planner  # noqa: E402
from nodnav.scenario.files import builtin_names  # noqa: E402
from nodnav.scenario.loading import load_scenario  # noqa: E402
from nodnav.sim.simulator import run_trial  # noqa: E402
from nodnav.viz.plan import save_plan_figure  # noqa: E402
from nodnav.viz.scenario import save_gallery, save_scenario_figure  # noqa: E402
from nodnav.viz.trial import save_animation, save_snapshots  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def short_trial():
    """Three simulated seconds of 2r-case1: enough for every panel to have something to show."""
    scenario = load_scenario("2r-case1").with_overrides(time_limit=3.0)
    return run_trial(scenario, "nod", 1)


def test_snapshot_figure(short_trial, tmp_path):
    path = save_snapshots(short_trial.history, tmp_path / "snap.png")
    assert path.read_bytes()[:8] == PNG
    assert imread(path).shape[0] > 100


def test_animation(short_trial, tmp_path):
    written = save_animation(short_trial.history, tmp_path / "trial.gif", stride=5)
    assert written[0].read_bytes()[:6] in (b"GIF87a", b"GIF89a")


def test_plan_figure(tmp_path):
    s = load_scenario("3r-case4")
    req = PlanRequest(world=s.world, positions=s.origins, velocities=np.zeros_like(s.origins),
                      destinations=s.destinations, radii=s.radii, max_speeds=s.max_speeds, order=(2, 0, 1))
    result = make_planner(s.planner, s.world).plan(req)
    assert result.success
    assert save_plan_figure(s, result, tmp_path / "plan.png").read_bytes()[:8] == PNG


def test_scenario_figure_and_gallery(tmp_path):
    assert save_scenario_figure(load_scenario("4r-case2"), tmp_path / "one.svg").read_text().lstrip().startswith("<")
    gallery = save_gallery([load_scenario(n) for n in builtin_names()[:3]], tmp_path / "all.png")
    assert gallery.read_bytes()[:8] == PNG
