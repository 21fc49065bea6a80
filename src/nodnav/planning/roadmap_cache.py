"""The roadmap cache on disk, and building every roadmap a world can need ahead of time.

Roadmaps (:mod:`nodnav.planning.roadmap`) are stored as ``.npz`` under a name derived from their
key's hash, with the key and a SHA-256 checksum inside; a file that does not parse, has another
key, fails its checksum or holds non-finite numbers is logged and rebuilt (:func:`get_roadmap`).
Writes go to a temporary file that is renamed into place, so concurrent processes never see a
partial file; temporary files that killed writers left behind are deleted once they are 15
minutes old. :func:`build_all_roadmaps` fills the cache for ``nodnav roadmaps build``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from nodnav.planning.roadmap import (
    BuildReport,
    LoadResult,
    Roadmap,
    RoadmapKey,
    RoadmapResult,
    build_roadmap,
    direction_patterns,
    make_key,
    roadmap_report,
)
from nodnav.scenario.world import World

log = logging.getLogger(__name__)


def resolve_cache_dir(cache_dir: str | os.PathLike = "") -> Path:
    """The roadmap cache directory: ``cache_dir`` if given, else ``$NODNAV_CACHE``, else
    ``~/.cache/nodnav``."""
    if str(cache_dir):
        return Path(cache_dir).expanduser()
    env = os.environ.get("NODNAV_CACHE", "")
    return Path(env).expanduser() if env else Path.home() / ".cache" / "nodnav"


def _checksum(key_text: str, vertices: np.ndarray, edges: np.ndarray, proximity: np.ndarray) -> str:
    h = hashlib.sha256(key_text.encode())
    for a in (vertices, edges, proximity):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


#: A ``.tmp-*.npz`` file in the cache older than this was left by a writer that was killed (s).
STALE_TEMPORARY_AGE = 900.0


def clean_stale_temporaries(directory: str | os.PathLike, max_age: float = STALE_TEMPORARY_AGE) -> list[Path]:
    """Delete the temporary files of :func:`save_roadmap` in ``directory`` older than ``max_age``
    seconds (a write takes a second; older ones belong to killed writers); the paths deleted."""
    removed = []
    now = time.time()
    for tmp in Path(directory).glob(".tmp-*.npz"):
        try:
            if now - tmp.stat().st_mtime > max_age:
                tmp.unlink()
                removed.append(tmp)
        except OSError:  # gone already, or not ours to delete
            continue
    if removed:
        log.info("removed %d stale temporary roadmap file(s) from %s", len(removed), directory)
    return removed


def save_roadmap(roadmap: Roadmap, directory: str | os.PathLike) -> Path:
    """Write ``roadmap`` atomically into ``directory`` (temp file + ``os.replace``); its path.
    Temporary files that killed writers left behind are removed first."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    clean_stale_temporaries(directory)
    path = directory / roadmap.key.filename()
    key_text = roadmap.key.canonical()
    vertices = np.ascontiguousarray(roadmap.vertices, dtype=np.float64)
    edges = np.ascontiguousarray(roadmap.edges, dtype=np.int32)
    proximity = np.ascontiguousarray(roadmap.proximity, dtype=np.float64)
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".tmp-", suffix=".npz")
    try:
        os.chmod(tmp, 0o644)  # a shared cache, not a private temporary file
        with os.fdopen(fd, "wb") as f:
            np.savez(f, key=np.array(key_text), checksum=np.array(_checksum(key_text, vertices, edges, proximity)),
                     vertices=vertices, edges=edges, proximity=proximity,
                     dropped_edges=np.array(roadmap.dropped_edges), build_seconds=np.array(roadmap.build_seconds))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_roadmap(path: str | os.PathLike, key: RoadmapKey) -> LoadResult:
    """Read a cache file and verify it: it parses, holds ``key``, matches its checksum and its
    arrays are consistent. Anything else is reported, never trusted."""
    path = Path(path)
    empty = Roadmap.empty(key)
    if not path.exists():
        return LoadResult(False, "no cached file", empty)
    try:
        with np.load(path, allow_pickle=False) as z:
            key_text = str(z["key"])
            checksum = str(z["checksum"])
            vertices = np.array(z["vertices"])
            edges = np.array(z["edges"])
            proximity = np.array(z["proximity"])
            dropped = int(z["dropped_edges"])
            build_seconds = float(z["build_seconds"])
    except Exception as exc:  # any failure to parse means a damaged file
        return LoadResult(False, f"unreadable ({type(exc).__name__}: {exc})", empty)
    if key_text != key.canonical():
        return LoadResult(False, "stored key differs (stale or foreign file)", empty)
    if checksum != _checksum(key_text, vertices, edges, proximity):
        return LoadResult(False, "checksum mismatch (corrupt file)", empty)
    dim = 2 * key.n_robots
    if (vertices.ndim != 2 or vertices.shape[1] != dim or edges.ndim != 2 or edges.shape[1] != 2
            or proximity.shape != (len(vertices),) or (len(edges) and (edges.min() < 0 or edges.max() >= len(vertices)))
            or not (np.isfinite(vertices).all() and np.isfinite(proximity).all())):
        return LoadResult(False, "inconsistent or non-finite arrays", empty)
    return LoadResult(True, "", Roadmap(key, vertices, edges, proximity, dropped, build_seconds))


def get_roadmap(key: RoadmapKey, cache_dir: str | os.PathLike = "", max_seconds: float = 3600.0) -> RoadmapResult:
    """The roadmap for ``key``: from the cache if a valid file is there, else built and stored."""
    directory = resolve_cache_dir(cache_dir)
    path = directory / key.filename()
    t0 = time.perf_counter()
    loaded = load_roadmap(path, key)
    if loaded.success:
        return RoadmapResult(loaded.roadmap, roadmap_report(key, True, "", time.perf_counter() - t0,
                                                            loaded.roadmap, True, str(path)))
    rebuilt = ""
    if path.exists():
        log.warning("roadmap cache %s rejected: %s; rebuilding", path, loaded.reason)
        rebuilt = f"cached file rejected ({loaded.reason}), rebuilt"
    built = build_roadmap(key, max_seconds)
    if not built.success:
        return built
    try:
        save_roadmap(built.roadmap, directory)
    except OSError as exc:
        log.warning("could not store roadmap in %s: %s", directory, exc)
        rebuilt = (rebuilt + "; " if rebuilt else "") + f"not cached ({exc})"
    return RoadmapResult(built.roadmap, dataclasses.replace(built.report, reason=rebuilt, path=str(path)))


def _get_report(key: RoadmapKey, cache_dir: str, max_seconds: float) -> BuildReport:
    return get_roadmap(key, cache_dir, max_seconds).report


def _indexed_report(i: int, key: RoadmapKey, cache_dir: str, max_seconds: float) -> tuple[int, BuildReport]:
    return i, _get_report(key, cache_dir, max_seconds)


def build_all_roadmaps(world: World, radius: float = 0.2, robot_counts=(1, 2, 3, 4), exited: bool = True,
                       vertices_per_robot: int | None = None, margin: float | None = None,
                       varsigma: float | None = None, cache_dir: str = "", n_jobs: int = 2,
                       max_seconds: float = 3600.0, progress=None) -> list[BuildReport]:
    """Build (or load) every roadmap that robots of equal ``radius`` can need in ``world``: all
    :func:`direction_patterns` for every robot count, in parallel processes (joblib).

    Defaults come from :class:`~nodnav.scenario.params.PRMParams`. Reports are returned in
    the order robot count, then pattern. ``progress(report, done, total_vertices)``, if given,
    is called as each roadmap is ready, with the vertices of all roadmaps as the total.
    """
    from joblib import Parallel, delayed

    from nodnav.scenario.params import PRMParams

    defaults = PRMParams()
    vpr = defaults.roadmap_vertices if vertices_per_robot is None else vertices_per_robot
    mg = defaults.margin if margin is None else margin
    vs = defaults.varsigma if varsigma is None else varsigma
    keys = [make_key(world, [radius] * n, p, mg, vs, vpr) for n in robot_counts for p in direction_patterns(n, exited)]
    # Largest first, so that the long builds do not end up last on one worker.
    order = sorted(range(len(keys)), key=lambda i: -keys[i].n_vertices)
    clean_stale_temporaries(resolve_cache_dir(cache_dir))
    total = sum(k.n_vertices for k in keys)
    by_index = {}
    tasks = (delayed(_indexed_report)(i, keys[i], cache_dir, max_seconds) for i in order)
    for i, report in Parallel(n_jobs=n_jobs, return_as="generator_unordered")(tasks):
        by_index[i] = report
        if progress is not None:
            progress(report, keys[i].n_vertices, total)
    return [by_index[i] for i in range(len(keys))]


def format_build_reports(reports: list[BuildReport]) -> str:
    """A table of build reports: one line per robot count, then the total."""
    lines = [f"{'robots':>6} {'roadmaps':>8} {'cached':>6} {'vertices':>9} {'edges':>9} {'dropped':>7} "
             f"{'build s':>8} {'failed':>6}"]
    for n in sorted({r.n_robots for r in reports}):
        rs = [r for r in reports if r.n_robots == n]
        ok = [r for r in rs if r.success]
        lines.append(f"{n:>6} {len(rs):>8} {sum(r.from_cache for r in rs):>6} "
                     f"{int(np.mean([r.vertices for r in ok])) if ok else 0:>9} "
                     f"{int(np.mean([r.edges for r in ok])) if ok else 0:>9} {sum(r.dropped_edges for r in ok):>7} "
                     f"{sum(r.build_seconds for r in ok):>8.1f} {len(rs) - len(ok):>6}")
    lines.append(f"total build time of these roadmaps {sum(r.build_seconds for r in reports):.1f} s "
                 f"(vertices and edges are means per roadmap)")
    lines += [f"failed n={r.n_robots} {r.pattern}: {r.reason}" for r in reports if not r.success]
    return "\n".join(lines)
