"""Registries: implementations registered by decorator and by entry point (a fake distribution
installed on ``sys.path``, found by :mod:`importlib.metadata` as a real one), and a name
registered twice refused in one clear line."""

import logging
import os
import subprocess
import sys
import textwrap
from dataclasses import dataclass, field

import pytest

from nodnav.registry import CONTROLLERS, METHODS, PLANNERS, Registry, RegistryError
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.params import MPCParams, PlannerParams


def install_distribution(tmp_path, monkeypatch, module: str, source: str, entry_points: dict[str, dict[str, str]]):
    """A distribution ``module`` 0.1 with one module of that name and the given entry points
    (group -> name -> target), on ``sys.path`` for this test only."""
    (tmp_path / f"{module}.py").write_text(textwrap.dedent(source))
    info = tmp_path / f"{module}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {module}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{name} = {target}\n" for name, target in points.items())
        for group, points in entry_points.items()))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, module, raising=False)  # imported afresh, and forgotten afterwards


@pytest.fixture
def fresh(monkeypatch):
    """The global registries with their built-ins, as if no entry point had been read yet; restored afterwards."""
    import nodnav.control  # noqa: F401  # the built-ins register when their layers are imported
    import nodnav.planning  # noqa: F401
    import nodnav.sim  # noqa: F401

    for registry in (PLANNERS, CONTROLLERS, METHODS):
        monkeypatch.setattr(registry, "_entries", dict(registry._entries))
        monkeypatch.setattr(registry, "_broken", {})
        monkeypatch.setattr(registry, "_plugins_loaded", False)


STRAIGHT = """
    from dataclasses import dataclass, field

    from nodnav.registry import register_planner
    from nodnav.scenario.params import PlannerParams


    @dataclass(frozen=True)
    class StraightParams(PlannerParams):
        speed_factor: float = field(default=0.5, metadata={"range": (0.1, 1.0, True)})


    @register_planner("straight", params=StraightParams)
    class StraightPlanner:
        '''Every robot straight to its destination.'''

        def __init__(self, world, params):
            self.params = params
"""


def test_a_planner_registered_by_its_modules_entry_point_is_named_in_a_scenario(tmp_path, monkeypatch, fresh):
    install_distribution(tmp_path, monkeypatch, "straight_plugin", STRAIGHT,
                         {"nodnav.planners": {"straight": "straight_plugin"}})
    assert "straight" in PLANNERS.names()
    scenario = load_scenario("2r-case1").with_overrides(**{"planner.name": "straight", "planner.speed_factor": 0.8})
    assert type(scenario.planner).__name__ == "StraightParams" and scenario.planner.speed_factor == 0.8
    assert PLANNERS.create("straight", scenario.world, scenario.planner).params is scenario.planner
    assert PLANNERS.get("straight").help == "Every robot straight to its destination"
    # Its settings are checked like a built-in's, in one line.
    with pytest.raises(ValueError, match=r"^planner.speed_factor: must be from 0.1 to 1, got 2$"):
        scenario.with_overrides(**{"planner.speed_factor": 2})


def test_an_implementation_named_by_an_entry_point_is_registered_under_its_name(tmp_path, monkeypatch, fresh):
    source = """
        class StandStill:
            '''Nobody moves.'''

            name = "stand-still"

            def __init__(self, scenario, rngs, planner=None):
                self.scenario = scenario
    """
    install_distribution(tmp_path, monkeypatch, "still_plugin", source,
                         {"nodnav.methods": {"stand-still": "still_plugin:StandStill"}})
    entry = METHODS.get("stand-still")
    assert entry.factory.__module__ == "still_plugin" and entry.params is None and entry.help == "Nobody moves"
    scenario = load_scenario("2r-case1")
    assert METHODS.create("stand-still", scenario, []).scenario is scenario


def test_a_plugin_controller_has_the_settings_every_controller_shares(tmp_path, monkeypatch, fresh):
    """The separation a controller keeps (which the simulation's reaction margin leaves free too)
    is a setting of every controller, a plugin's included, not only of the MPC."""
    source = """
        from dataclasses import dataclass

        from nodnav.registry import register_controller
        from nodnav.scenario.params import ControllerParams


        @dataclass(frozen=True)
        class BrakeParams(ControllerParams):
            pass


        @register_controller("brake", params=BrakeParams)
        class Brake:
            def __init__(self, world, robot, params):
                self.params = params
    """
    install_distribution(tmp_path, monkeypatch, "brake_plugin", source,
                         {"nodnav.controllers": {"brake": "brake_plugin"}})
    scenario = load_scenario("2r-case1").with_overrides(**{"controller.name": "brake"})
    assert scenario.controller.safety_margin == MPCParams().safety_margin
    changed = scenario.with_overrides(**{"controller.safety_margin": 0.1})
    assert type(changed.controller).__name__ == "BrakeParams" and changed.controller.safety_margin == 0.1


def test_a_plugin_that_fails_to_import_is_left_out_and_its_name_says_why(tmp_path, monkeypatch, fresh, caplog):
    install_distribution(tmp_path, monkeypatch, "broken_plugin", "import not_a_module_anywhere\n",
                         {"nodnav.controllers": {"broken": "broken_plugin"}})
    with caplog.at_level(logging.WARNING, logger="nodnav.registry"):
        assert "broken" not in CONTROLLERS.names() and "mpc" in CONTROLLERS.names()
    assert "controller plugin 'broken' (broken_plugin) failed to load" in caplog.text
    with pytest.raises(RegistryError, match="^controller 'broken' could not be loaded: ModuleNotFoundError"):
        CONTROLLERS.get("broken")
    with pytest.raises(ValueError, match="^controller.name: controller 'broken' could not be loaded"):
        load_scenario("2r-case1").with_overrides(**{"controller.name": "broken"})


def test_an_entry_point_cannot_take_a_built_in_name(tmp_path, monkeypatch, fresh, caplog):
    source = """
        class Impostor:
            '''Not the fast planner.'''
    """
    install_distribution(tmp_path, monkeypatch, "impostor_plugin", source,
                         {"nodnav.planners": {"fast": "impostor_plugin:Impostor"}})
    with caplog.at_level(logging.WARNING, logger="nodnav.registry"):
        PLANNERS.load_plugins()
    assert PLANNERS.get("fast").factory.__module__ == "nodnav.planning.prioritized"
    assert ("planner plugin 'fast' (impostor_plugin:Impostor) not registered: planner 'fast' is registered already "
            "(by nodnav.planning.prioritized.PrioritizedPlanner)") in caplog.text


def test_a_plugin_read_before_the_planners_are_imported_cannot_take_a_built_in_name(tmp_path, monkeypatch):
    """Loading a scenario reads the entry points while only the built-ins' parameters are declared
    (the planners register when nodnav.planning is imported): the impostor must not fill the slot."""
    install_distribution(tmp_path, monkeypatch, "impostor_plugin", "class Impostor:\n    pass\n",
                         {"nodnav.planners": {"fast": "impostor_plugin:Impostor"}})
    code = ("from nodnav.scenario.loading import load_scenario; from nodnav.registry import PLANNERS; "
            "load_scenario('2r-case1'); assert PLANNERS.get('fast').factory is None; "
            "import nodnav.planning; print(PLANNERS.get('fast').factory.__name__)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(tmp_path)})
    assert done.returncode == 0 and done.stdout.split() == ["PrioritizedPlanner"], done.stderr
    assert "planner 'fast' is declared already by nodnav (nodnav.scenario.params.FastPlannerParams)" in done.stderr


# -- registering by decorator ------------------------------------------------------------------------


@dataclass(frozen=True)
class ToyParams(PlannerParams):
    width: float = field(default=1.0, metadata={"range": (0.0, 2.0, False)})


@pytest.fixture
def toys():
    """A registry of its own, so that nothing registered here reaches nodnav's."""
    return Registry("toy", "nodnav.tests.no-such-group")


def test_the_same_name_twice_is_refused_in_one_line_and_the_first_stays(toys):
    @toys.register("one", params=ToyParams)
    class First:
        pass

    class Second:
        pass

    with pytest.raises(RegistryError) as error:
        toys.register("one")(Second)
    assert str(error.value) == f"toy 'one' is registered already (by {__name__}.{First.__qualname__})"
    assert toys.get("one").factory is First
    toys.register("one")(First)  # the same implementation again (a module imported twice) is no error
    assert toys.names() == ("one",)


def test_a_second_parameter_class_for_a_name_is_refused(toys):
    @dataclass(frozen=True)
    class OtherParams(PlannerParams):
        pass

    class Two:
        pass

    toys.declare("two", params=ToyParams)(ToyParams)
    with pytest.raises(RegistryError, match="^toy 'two': its parameters are declared already as ToyParams$"):
        toys.register("two", params=OtherParams)(Two)
    toys.register("two")(Two)  # the implementation of a declared name takes the declared parameters
    assert toys.get("two").params is ToyParams and toys.get("two").factory is Two


def test_a_declared_name_is_kept_for_its_own_package(toys):
    """nodnav declares its built-in names before their implementations register (in a higher
    layer); a plugin loaded in between must not fill them."""
    toys.declare("three")(ToyParams)
    with pytest.raises(RegistryError, match=r"^toy 'three' is declared already by \w+ \(.*ToyParams\); register "
                                            "yours under another name$"):
        toys.register("three")(dict)
    assert toys.get("three").factory is None


@pytest.mark.parametrize("name", ["Upper", "with space", "", "x" * 41, "-leading"])
def test_a_malformed_name_is_refused(toys, name):
    with pytest.raises(RegistryError, match="use lower-case letters, digits"):
        toys.register(name)(object)


def test_parameters_must_be_a_frozen_dataclass(toys):
    @dataclass
    class Mutable:
        x: float = 1.0

    with pytest.raises(RegistryError, match="^toy 'm': its parameters must be a frozen dataclass"):
        toys.register("m", params=Mutable)(object)


def test_an_unknown_name_suggests_the_nearest(toys):
    toys.register("straight")(object)
    with pytest.raises(RegistryError, match="^unknown toy 'straigth'.*straight"):
        toys.get("straigth")
