"""Recorded planner or controller calls replayed through one checkout, or two side by side: the
processor time of exactly the same calls, and a digest proving both computed the same answers
(docs/performance-16.md measured its bitwise changes this way).

A trial's time is noisy on a shared machine and a changed trajectory changes the work, so a whole
trial says little about a change of a few per cent. Here the calls are fixed: ``record`` runs the
trials of a scenario once and keeps every request of one kind with what builds the object that
answered it; ``replay`` and ``pair`` answer the same requests again, in the same order, in new
objects (planners and controllers keep state between calls: each is rebuilt and fed its own
sequence, so its caches and warm starts go through the same states as in the trial).

    python tools/replay_calls.py record planner case1.pkl 4r-case1 --seeds 3 [--players K]
    python tools/replay_calls.py record control ctl1.pkl 4r-case1 --seeds 3
    python tools/replay_calls.py replay case1.pkl [--repeats 5]
    python tools/replay_calls.py pair case1.pkl /path/to/base /path/to/new [--pairs 30] [--launches 3] [--core 0]

``planner`` records every :meth:`PrioritizedPlanner.plan` request, with its planner's world and
parameters and which planner asked; ``control`` every :meth:`BSplineMPC.control` request, with
the scenario of the method whose controller asked (the replay builds each method's controllers
again, sharing one :class:`SharedSetups`, as the trial did). Arrays that the trial may write to
later are copied when recorded; on loading, the arrays of the requests are made again as a run
makes them (NumPy's own dtype objects, read-only where they were, one object where the trial
passed one object several times: the controllers check such arrays once).

``replay`` answers the requests once untimed (kernels load at their first call; then the heap is
frozen, as sweep workers do), then ``--repeats`` times into new objects, and prints the best and
the median processor time of the calls (the objects are built before the clock starts) and a
digest of every answer: arrays as bytes, reasons, flags, costs, orders and diagnostics (not the
wall times the answers carry). The recording holds the same digest of the trial's own answers: a
replay that gives it answered exactly as the trial did (exit code 1 if not).

``pair`` runs one worker process per checkout (a directory holding ``src/nodnav``:
``git archive COMMIT src | tar -x -C DIR``), each with ``PYTHONPATH=<checkout>/src``, a kernel
cache of its own and the checkout's ``.venv/bin/python`` if it has one, both pinned to core
``--core``. They take turns, the first of each pair alternating, ``--pairs`` pairs, and
``--launches`` times with new worker processes (a process's memory layout alone moves its times
by a per cent or two). It prints both digests ("same" or "different", exit code 1) and, over all
pairs, B's time over A's: the median with the quartiles, the best B over the best A, and the
median of each launch. Two copies of one commit show the tool's own noise: on this shared
machine, 4r-case1 seeds 1-3, the median of one launch came out 0.965-1.016 and that of all the
pairs of 3-5 launches 0.994-0.999 (planner and control calls), so a change of 3 % shows in one
run; for 1-2 % take more launches and see that the launches' medians agree.

What it cannot say: a recording is the calls of one checkout's trials. A change that changes a
trajectory changes the calls that follow, which the recording does not; its replay answers
requests the changed trial would not make, and the digests differ. Replay measures changes that
keep the calls the same (bitwise changes), and only the recorded kind of call: time moved into
or out of the calls does not show. The recording is a pickle of the recording checkout's
objects; both checkouts must still load it.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import gc
import hashlib
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

FORMAT = "nodnav replay_calls 1"
KINDS = ("planner", "control")
# Fields of an answer that hold wall times, left out of the digest.
WALL_TIMES = frozenset({"compute_time", "solve_time", "qp_time"})


class InputError(Exception):
    """Something the user typed that the tool cannot use; one line, exit code 2."""


# -- recording -------------------------------------------------------------------------------


def _kept(request):
    """A copy of ``request`` whose writeable arrays are copies: the trial may write to them after
    the call (read-only ones are kept as they are, shared between requests as in the trial)."""
    kept = copy.copy(request)
    kept.__dict__.update({k: v.copy() for k, v in request.__dict__.items()
                          if isinstance(v, np.ndarray) and v.flags.writeable})
    return kept


def record(kind: str, scenario, seeds: list[int]) -> dict:
    """Run ``scenario``'s trials of ``seeds`` and return the recording of their ``kind`` calls:
    ``makers`` (what builds each answering object, in the order the trials built them) and
    ``calls`` (``(object number, request)``, in the order they were made)."""
    from nodnav.sim.simulator import run_trial

    makers: list = []
    calls: list = []
    answered = hashlib.sha256()  # the trial's answers, each hashed as it is given
    number: dict[int, int] = {}
    alive: list = []  # the objects numbered, kept so that no id is used twice

    def numbered(obj) -> int:
        if id(obj) not in number:
            number[id(obj)] = len(number)
            alive.append(obj)
        return number[id(obj)]

    def numbered_planner(planner) -> int:
        if id(planner) not in number:
            makers.append((type(planner), planner.world, planner.params))
        return numbered(planner)

    def recording(original, number_of):
        def call(self, request):
            calls.append((number_of(self), _kept(request)))
            out = original(self, request)
            _feed(answered, out)
            return out
        return call

    if kind == "planner":
        from nodnav.planning.prioritized import PrioritizedPlanner
        patches = [(PrioritizedPlanner, "plan", recording(PrioritizedPlanner.plan, numbered_planner))]
    elif kind == "control":
        from nodnav.control.mpc import BSplineMPC
        from nodnav.sim.methods import PlannedMethod
        init = PlannedMethod.__init__

        def method_init(self, scenario, *args, **kwargs):
            init(self, scenario, *args, **kwargs)
            makers.append(scenario)
            for controller in self.controllers:
                numbered(controller)
        patches = [(PlannedMethod, "__init__", method_init),
                   (BSplineMPC, "control", recording(BSplineMPC.control, lambda mpc: number[id(mpc)]))]
    else:
        raise InputError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    originals = [(owner, name, owner.__dict__[name]) for owner, name, _ in patches]
    for owner, name, replacement in patches:
        setattr(owner, name, replacement)
    try:
        for seed in seeds:
            run_trial(scenario, seed=seed)
    finally:
        for owner, name, original in originals:
            setattr(owner, name, original)
    if not calls:
        raise InputError(f"the trials made no {patches[-1][0].__name__}.{patches[-1][1]} calls")
    return {"format": FORMAT, "kind": kind, "scenario": scenario.name, "seeds": list(seeds),
            "players": scenario.game_players, "makers": makers, "calls": calls, "digest": answered.hexdigest()[:16]}


# -- loading and replaying -------------------------------------------------------------------


def _as_made(calls: list) -> None:
    """Make the requests' arrays again as a run makes them, in place: unpickled arrays carry
    dtype objects of their own, which compiled code looks up more slowly than NumPy's. One array
    of the recording stays one array; read-only stays read-only."""
    made: dict[int, np.ndarray] = {}
    for _, request in calls:
        fields = {}
        for key, value in request.__dict__.items():
            if isinstance(value, np.ndarray):
                if id(value) not in made:
                    out = np.empty(value.shape, dtype=np.dtype(value.dtype.str))
                    out[...] = value
                    out.setflags(write=value.flags.writeable)
                    made[id(value)] = out
                fields[key] = made[id(value)]
        request.__dict__.update(fields)


def load(path: str) -> dict:
    """The recording in the file ``path``, its requests' arrays made as a run makes them."""
    try:
        with open(path, "rb") as f:
            recording = pickle.load(f)
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror}") from None
    except Exception as exc:  # not a pickle, or one of objects this checkout cannot build
        raise InputError(f"{path} is not a recording this checkout can load ({type(exc).__name__}: {exc})") from None
    if not isinstance(recording, dict) or recording.get("format") != FORMAT:
        raise InputError(f"{path} is not a recording of tools/replay_calls.py")
    _as_made(recording["calls"])
    return recording


def build(recording: dict) -> list:
    """New answering objects, numbered as in the recording."""
    if recording["kind"] == "planner":
        return [cls(world, params) for cls, world, params in recording["makers"]]
    from nodnav.control import SharedSetups, make_controller
    objects = []
    for scenario in recording["makers"]:
        shared = SharedSetups()  # one per method, as PlannedMethod builds them
        objects += [make_controller(scenario.controller, scenario.world, robot, shared) for robot in scenario.robots]
    return objects


def answer(recording: dict, objects: list) -> list:
    """The answers of ``objects`` to the recorded requests, in order."""
    name = "plan" if recording["kind"] == "planner" else "control"
    methods = [getattr(obj, name) for obj in objects]
    return [methods[k](request) for k, request in recording["calls"]]


def timed(recording: dict) -> tuple[float, list]:
    """The processor time of answering every request in new objects (built before the clock
    starts), and the answers."""
    objects = build(recording)
    start = time.process_time()
    answers = answer(recording, objects)
    return time.process_time() - start, answers


def _feed(h, value) -> None:
    """Add ``value`` to the hash ``h``: arrays as dtype, shape and bytes, floats by their exact
    repr, containers and objects field by field (wall times left out)."""
    if isinstance(value, np.ndarray):
        h.update(f"{value.dtype.str}{value.shape}".encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, dict):
        h.update(b"{%d" % len(value))
        for key in sorted(value, key=repr):
            if key not in WALL_TIMES:
                _feed(h, key)
                _feed(h, value[key])
    elif isinstance(value, (list, tuple)):
        h.update(b"(%d" % len(value))
        for item in value:
            _feed(h, item)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(type(value).__name__.encode())
        _feed(h, {f.name: getattr(value, f.name) for f in dataclasses.fields(value)})
    else:
        h.update(repr(value).encode())


def digest(answers: list) -> str:
    """A short hash of every answer: equal digests, bitwise equal answers."""
    h = hashlib.sha256()
    for out in answers:
        _feed(h, out)
    return h.hexdigest()[:16]


def _warmed(recording: dict) -> str:
    """Answer every request once, untimed (kernels load at their first call), freeze the heap
    where the checkout can (as sweep workers do), and return the answers' digest."""
    _, answers = timed(recording)
    try:
        from nodnav.heap import freeze_long_lived
    except ImportError:
        gc.collect()
    else:
        freeze_long_lived()
    return digest(answers)


def _describe(recording: dict) -> str:
    players = "all" if recording["players"] is None else recording["players"]
    return (f"{len(recording['calls'])} {recording['kind']} calls of {len(recording['makers'])} "
            f"{'planners' if recording['kind'] == 'planner' else 'methods'}, {recording['scenario']} seeds "
            f"{','.join(map(str, recording['seeds']))}, players {players}")


# -- two checkouts ---------------------------------------------------------------------------


def _worker(path: str, core: int) -> None:
    """Pinned to ``core``: warm up, say ``ready DIGEST NODNAV_DIR``, then time one replay for every
    line read."""
    import nodnav

    os.sched_setaffinity(0, {core})
    recording = load(path)
    print("ready", _warmed(recording), Path(nodnav.__file__).parent, flush=True)
    for _ in sys.stdin:
        print(timed(recording)[0], flush=True)


def _checkout(directory: str) -> Path:
    path = Path(directory).resolve()
    if not (path / "src" / "nodnav" / "__init__.py").is_file():
        raise InputError(f"{directory} is not a checkout: it has no src/nodnav")
    return path


def _launch(checkout: Path, path: str, core: int) -> tuple[subprocess.Popen, str, str]:
    """A worker importing ``checkout``'s nodnav, once it is ready: the process, its digest and
    the nodnav it imported."""
    # A kernel cache per checkout, kept between runs (as tools/commit_ab.py's: compiling takes minutes).
    cache = Path(tempfile.gettempdir()) / "nodnav-ab-kernels" / hashlib.sha256(str(checkout).encode()).hexdigest()[:12]
    python = checkout / ".venv" / "bin" / "python"
    env = dict(os.environ, PYTHONPATH=str(checkout / "src"), NUMBA_CACHE_DIR=str(cache))
    proc = subprocess.Popen([str(python) if python.exists() else sys.executable, __file__, "--worker", path, str(core)],
                            env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline().split()
    if len(line) != 3 or line[0] != "ready":
        proc.kill()
        raise RuntimeError(f"the worker of {checkout} failed (its error is above)")
    if Path(line[2]).resolve() != checkout / "src" / "nodnav":
        proc.kill()
        raise RuntimeError(f"the worker of {checkout} imported nodnav from {line[2]}")
    return proc, line[1], line[2]


def _paired_times(workers: list, pairs: int) -> list[list[float]]:
    """The replay times of the two workers, ``pairs`` each, taking turns: A first in even
    pairs, B first in odd ones."""
    times: list[list[float]] = [[], []]
    for i in range(pairs):
        for w in (0, 1) if i % 2 == 0 else (1, 0):
            proc = workers[w][0]
            proc.stdin.write("go\n")
            proc.stdin.flush()
            line = proc.stdout.readline()
            if not line:
                raise RuntimeError(f"a worker stopped after {i} pairs (its error is above)")
            times[w].append(float(line))
    for proc, _, _ in workers:
        proc.stdin.close()
        proc.wait()
    return times


def pair(path: str, a: str, b: str, pairs: int, launches: int, core: int) -> int:
    """Replay ``path`` through checkouts ``a`` and ``b`` in turns (``pairs`` pairs in each of
    ``launches`` pairs of worker processes) and print the paired figures; returns 0 if both
    answered the same, 1 if not."""
    checkouts = _checkout(a), _checkout(b)
    recording = load(path)
    print(_describe(recording))
    times: list[list[float]] = [[], []]
    medians, digests = [], set()
    for launch in range(launches):
        workers = [_launch(c, path, core) for c in checkouts]
        if launch == 0:
            for label, checkout, (_, dig, where) in zip("AB", checkouts, workers):
                trial = "the trial's" if dig == recording["digest"] else f"the trial's was {recording['digest']}"
                print(f"{label} {checkout}: digest {dig} ({trial}; nodnav from {where})")
        digests.update((label, w[1]) for label, w in zip("AB", workers))
        ta, tb = _paired_times(workers, pairs)
        medians.append(statistics.median(b / a for a, b in zip(ta, tb)))
        times[0] += ta
        times[1] += tb
    same = len({dig for _, dig in digests}) == 1
    print("digests: " + ("same" if same else "different"))
    ratios = [tb / ta for ta, tb in zip(*times)]
    quartiles = statistics.quantiles(ratios, n=4, method="inclusive") if len(ratios) > 1 else ratios * 3
    for label, t in zip("AB", times):
        print(f"{label}: best {min(t) * 1e3:.1f} ms, median {statistics.median(t) * 1e3:.1f} ms")
    print(f"B/A over {len(ratios)} pairs on core {core}: median {quartiles[1]:.3f} (quartiles {quartiles[0]:.3f}-"
          f"{quartiles[2]:.3f}), best B / best A {min(times[1]) / min(times[0]):.3f}")
    if launches > 1:
        print("median B/A of each launch: " + " ".join(f"{m:.3f}" for m in medians))
    return 0 if same else 1


# -- command line ----------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="replay_calls.py", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="record the calls of a scenario's trials")
    rec.add_argument("kind", help="planner or control")
    rec.add_argument("out")
    rec.add_argument("scenario", help="a built-in scenario's name or a scenario file")
    rec.add_argument("--seeds", type=int, default=1, help="seeds 1..N (default 1)")
    rec.add_argument("--players", help="game players, a number or 'all' (default: the scenario's)")
    rep = sub.add_parser("replay", help="replay a recording in this checkout")
    rep.add_argument("recording")
    rep.add_argument("--repeats", type=int, default=5)
    two = sub.add_parser("pair", help="replay a recording through two checkouts in turns")
    two.add_argument("recording")
    two.add_argument("a", metavar="CHECKOUT_A")
    two.add_argument("b", metavar="CHECKOUT_B")
    two.add_argument("--pairs", type=int, default=30, help="pairs of replays per launch (default 30)")
    two.add_argument("--launches", type=int, default=3, help="worker pairs, one after another (default 3)")
    two.add_argument("--core", type=int, default=0)
    return parser


def _run(args: argparse.Namespace) -> int:
    if args.command == "record":
        if args.kind not in KINDS:
            raise InputError(f"kind must be one of {', '.join(KINDS)}, got {args.kind!r}")
        if args.seeds < 1:
            raise InputError(f"--seeds must be at least 1, got {args.seeds}")
        from nodnav.scenario.loading import load_scenario
        scenario = load_scenario(args.scenario)
        if args.players is not None:
            players = int(args.players) if args.players.isdigit() else args.players
            scenario = scenario.with_overrides(game_players=players)
        recording = record(args.kind, scenario, list(range(1, args.seeds + 1)))
        with open(args.out, "wb") as f:
            pickle.dump(recording, f, protocol=pickle.HIGHEST_PROTOCOL)
        print(f"{args.out}: {_describe(recording)}")
        return 0
    if args.command == "replay":
        recording = load(args.recording)
        first = _warmed(recording)
        seconds, same = [], True
        for _ in range(max(1, args.repeats)):
            cpu, answers = timed(recording)
            seconds.append(cpu)
            same &= digest(answers) == first
        trial = "the trial's" if first == recording["digest"] else f"DIFFERS from the trial's {recording['digest']}"
        print(f"{_describe(recording)}: best {min(seconds) * 1e3:.1f} ms, median "
              f"{statistics.median(seconds) * 1e3:.1f} ms of {len(seconds)}; digest {first} ({trial})"
              + ("" if same else " (DIFFERS between repeats)"))
        return 0 if same and first == recording["digest"] else 1
    if args.pairs < 1 or args.launches < 1:
        raise InputError("--pairs and --launches must be at least 1")
    return pair(args.recording, args.a, args.b, args.pairs, args.launches, args.core)


def main(argv: list[str]) -> int:
    if argv[:1] == ["--worker"]:
        _worker(argv[1], int(argv[2]))
        return 0
    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except InputError as exc:
        print(f"replay_calls: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:
        from nodnav.errors import NodnavError, one_line  # a scenario that does not load, a bad --players
        if isinstance(exc, NodnavError):
            print(f"replay_calls: error: {one_line(exc)}", file=sys.stderr)
            return 2
        raise


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
