"""Fuzzing: thousands of mutated scenarios at the loader and argument lists at the command line.

The property: whatever comes in, the only exception that leaves the loader is the package's own
(:class:`~nodnav.errors.NodnavError`), every message is one line of bounded length, and the
command line answers 0 or 2 with at most one ``nodnav: error: ...`` line, never a traceback or
an internal error. The command line runs with ``execute=False``: every check of every command
runs (scenario files, options, output paths), the long work (trials, sweeps) does not.
"""

from __future__ import annotations

import contextlib
import copy
import io
import os

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from nodnav.cli import main
from nodnav.errors import MAX_MESSAGE, NodnavError
from nodnav.scenario.files import builtin_names
from nodnav.scenario.loading import load_scenario
from nodnav.scenario.schema import Scenario, scenario_from_dict, scenario_to_dict

KEYS = ["name", "description", "world", "robot_defaults", "robots", "opinion", "game_players", "time_limit",
        "planner", "controller", "sim", "bounds", "obstacles", "corridor", "entrances", "corridor_width", "x_min",
        "x_max", "y_min", "y_max", "origin", "destination", "radius", "max_speed", "max_accel", "u", "d", "eta",
        "K1", "T", "alpha_min", "init", "z0", "K2", "delta", "bias", "dt", "horizon", "w1", "w2", "margin",
        "roadmap_vertices", "cache_dir", "waiting", "door_clearance", "varsigma", "safety_margin", "goal_tolerance",
        "collision_tolerance", "deadlock_time", "progress_epsilon", "observation_noise", "S1", "S2", "S²", "S①",
        "S" + "9" * 5000, "S0", "S-1", "../escaped", 3, 2.5, None, True]

SPECIAL = [10**400, -10**400, 10**5000, 5e-324, -5e-324, 1e308, -1e308, float("nan"), float("inf"), float("-inf"),
           0, -1, 1, 2, 0.0, -0.0, 1e-9, 1e4, 1e6, 2**63, "all", "given", "zero", "distance", "fast", "prm",
           "mpc", "early", "late", "", "\n", "a\nb", "../escaped", "S²", "1e3", "x" * 5000, "\0", [], {}, [0, 0],
           [-3.0, 0.0], [3.0, 0.0], [[0, 0], [0, 0]], [-7, -2.5, 7, 2.5], [1, 2, 3, 4]]

# Indices, not the values, go into the strategy: hypothesis prints its strategies, and Python
# refuses to print integers of 5000 digits.
def _special(i: int):
    return SPECIAL[i]


special = st.integers(0, len(SPECIAL) - 1).map(_special)
leaves = st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=12), special,
                   st.sampled_from(KEYS))
values = st.recursive(leaves, lambda inner: st.one_of(
    st.lists(inner, max_size=5), st.dictionaries(st.sampled_from(KEYS).filter(lambda k: k is not None) | st.text(
        max_size=6), inner, max_size=5)), max_leaves=20)

BASES = [scenario_to_dict(load_scenario(n)) for n in builtin_names()]


def _nested(depth: int):
    value: object = 1.0
    for _ in range(depth):
        value = [value]
    return value


@st.composite
def mutated_scenarios(draw):
    """A built-in scenario's mapping with a few values replaced, removed, added or nested deeply."""
    raw = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 4))):
        target = raw
        for _ in range(draw(st.integers(0, 4))):  # walk down a random existing path
            children = list(target) if isinstance(target, dict) else list(range(len(target))) \
                if isinstance(target, list) else []
            children = [c for c in children if isinstance(target[c], (dict, list))]
            if not children:
                break
            target = target[draw(st.sampled_from(children))]
        if isinstance(target, dict):
            key = draw(st.sampled_from(sorted(target, key=str) + KEYS[:12]) if target else st.sampled_from(KEYS))
        elif isinstance(target, list) and target:
            key = draw(st.integers(0, len(target) - 1))
        else:
            continue
        action = draw(st.sampled_from(["set", "set", "set", "delete", "deep"]))
        if action == "delete":
            with contextlib.suppress(KeyError, IndexError, TypeError):
                del target[key]
        elif action == "deep":
            target[key] = _nested(draw(st.sampled_from([50, 1000, 3000])))
        else:
            # A copy: later mutations may walk into it, and hypothesis may hand out the same object again.
            target[key] = copy.deepcopy(draw(values))
    return raw


def _check_message(exc: BaseException) -> None:
    assert isinstance(exc, NodnavError), f"{type(exc).__name__} escaped: {exc!r}"[:500]
    text = str(exc)
    assert "\n" not in text and 0 < len(text) <= 2 * MAX_MESSAGE, text[:300]


@settings(max_examples=2500, deadline=None, suppress_health_check=list(HealthCheck))
@given(mutated_scenarios())
def test_loader_raises_only_its_own_error_in_one_line(raw):
    try:
        scenario = scenario_from_dict(raw)
    except Exception as exc:  # noqa: BLE001 - the property is about what escapes
        _check_message(exc)
    else:
        assert isinstance(scenario, Scenario)
        # What was accepted reads back to itself (the form stored with every trial).
        assert scenario_from_dict(scenario_to_dict(scenario)) == scenario


def _dump(raw) -> bytes:
    try:
        return yaml.safe_dump(raw, allow_unicode=True).encode()
    except (RecursionError, yaml.YAMLError, ValueError):  # deeper than PyYAML writes, or a huge integer
        return b"robots: [" * 600

@settings(max_examples=600, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.one_of(st.binary(max_size=200), st.text(max_size=200).map(str.encode),
                 mutated_scenarios().map(_dump).filter(lambda b: len(b) < 200_000)))
def test_loading_any_file_raises_only_its_own_error(tmp_path_factory, content):
    path = tmp_path_factory.mktemp("files", numbered=True) / "s.yaml"
    path.write_bytes(content)
    try:
        load_scenario(path)
    except Exception as exc:  # noqa: BLE001
        _check_message(exc)


COMMANDS = ["scenarios", "show", "heatmap", "plan", "run", "sweep", "bench", "roadmaps", "replay", "reproduce",
            "report", "nope"]
OPTIONS = ["--out", "--u", "--grid", "--json", "--order", "--planner", "--seed", "--players", "--init", "--bias",
           "--method", "--noise", "--study", "--name", "--scenario", "--trials", "--db", "--jobs", "--scheduler",
           "--retry-errors", "--allow-mixed", "--quiet", "--robots", "--vertices", "--cache-dir", "--no-animation",
           "--methods", "--planners", "--budget", "--fig2c-grid", "--fig2c-trials", "--method-trials", "--parts",
           "--scenarios", "--heatmap-grid", "--no-rerun", "-v", "--help", "--bogus"]
WORDS = ["2r-case1", "3r-case4", "all", "build", "sim", "mpc", "planners", "fast", "prm", "nod", "orca", "zero",
         "distance", "none", "S3=150", "S3=150,S5=150", "S²=5", "S①=1", "S" + "9" * 5000 + "=1", "S3=nan",
         "2,1,3", "1,1,3", "1,2", "-1", "0", "1", "2", "3", "²", "10" + "0" * 400, "1e400", "nan", "inf", "-inf",
         "5e-324", "1e9", "x.xyz", "x.png", "adir", "afile", "bad.yaml", "bad.sqlite", "good.yaml", "text.npz",
         "../escaped", "", " ", "\n", "é", "success,table1", "bogus", "foo,bar", "1,2,3,4", "7", "tcp://nowhere:1"]


@st.composite
def argument_lists(draw):
    argv = [draw(st.sampled_from(COMMANDS))]
    for _ in range(draw(st.integers(0, 6))):
        kind = draw(st.sampled_from(["option", "option", "word", "text"]))
        if kind == "option":
            argv.append(draw(st.sampled_from(OPTIONS)))
            if draw(st.booleans()):
                argv.append(draw(st.sampled_from(WORDS)))
        elif kind == "word":
            argv.append(draw(st.sampled_from(WORDS)))
        else:
            argv.append(draw(st.text(max_size=10).filter(lambda t: "\0" not in t)))
    return argv


@settings(max_examples=2500, deadline=None, suppress_health_check=list(HealthCheck))
@given(argument_lists())
def test_command_line_answers_in_one_line(tmp_path_factory, argv):
    home = tmp_path_factory.getbasetemp() / "cli-fuzz"
    if not home.exists():
        home.mkdir()
        (home / "adir").mkdir()
        (home / "afile").write_text("a file\n")
        (home / "bad.yaml").write_bytes(b"\xff\xfe not utf-8")
        (home / "bad.sqlite").write_bytes(b"SQLite format 3\0" + bytes(range(256)) * 8)
        (home / "text.npz").write_text("not a history\n")
        (home / "good.yaml").write_text("robots:\n  - {origin: [-5, 0], destination: [5, 0]}\n")
    err, out = io.StringIO(), io.StringIO()
    cwd, cache = os.getcwd(), os.environ.get("NODNAV_CACHE")
    os.chdir(home)
    os.environ["NODNAV_CACHE"] = str(home / "cache")
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            code = main(argv, execute=False)
    finally:
        os.chdir(cwd)
        if cache is None:
            os.environ.pop("NODNAV_CACHE", None)
        else:
            os.environ["NODNAV_CACHE"] = cache
    text = err.getvalue()
    assert code in (0, 2), (argv, code, text[:500])
    assert "Traceback" not in text and "internal error" not in text, text[:500]
    if code == 2:
        lines = text.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("nodnav: error: "), (argv, text[:500])
        assert len(lines[0]) <= MAX_MESSAGE + len("nodnav: error: ")
