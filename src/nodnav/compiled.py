"""The decorator of the package's compiled scalar loops.

Hot inner loops (planner timing, roadmap checks, MPC rows, predictions) are written as plain
scalar Python and compiled by numba, cached on disk. Without numba the same code runs as Python,
slowly but with the same results.

Where the cache lives, and why not next to the module (numba's default): numba decides whether
a cached kernel is stale from its own source file only, but a kernel that calls a kernel of
another module has the callee compiled into it. After an edit or an upgrade that changes only
the callee, the caller would load the old callee's code from the cache: wrong results, or a
crash where array layouts changed (a segmentation fault in the braking tail's clearance on a map
was one, after two branches were merged). So every kernel of one version of the package's
source is cached in a directory of its own, named after a hash of all its ``.py`` files
(:func:`kernel_cache_dir`): a change anywhere compiles everything afresh, once. The directory is
under ``$NODNAV_CACHE/kernels/`` (else ``$NUMBA_CACHE_DIR/nodnav/``, else
``~/.cache/nodnav/kernels/``); directories of versions not
used for :data:`PRUNE_AGE_DAYS` days are removed when a new one is made.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import time
from pathlib import Path

#: Kernel directories of other source versions unused for this long are removed (days).
PRUNE_AGE_DAYS = 30.0


def source_digest(root: Path) -> str:
    """SHA-256 (hex) over the relative path and bytes of every ``.py`` file under ``root``, sorted."""
    h = hashlib.sha256()
    files = sorted((p for p in root.rglob("*.py") if "__pycache__" not in p.parts), key=lambda p: p.as_posix())
    for p in files:
        rel = p.relative_to(root).as_posix().encode()
        data = p.read_bytes()
        h.update(len(rel).to_bytes(4, "little") + rel + len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


def kernel_cache_root() -> Path:
    """``$NODNAV_CACHE/kernels`` (the roadmap cache's parent rule), else ``$NUMBA_CACHE_DIR/nodnav``
    (numba's own setting, respected), else ``~/.cache/nodnav/kernels``."""
    env = os.environ.get("NODNAV_CACHE", "")
    if env:
        return Path(env).expanduser() / "kernels"
    numba_dir = os.environ.get("NUMBA_CACHE_DIR", "")
    if numba_dir:
        return Path(numba_dir).expanduser() / "nodnav"
    return Path.home() / ".cache" / "nodnav" / "kernels"


def prune_kernel_dirs(root: Path, keep: Path, max_age_days: float = PRUNE_AGE_DAYS) -> list[Path]:
    """Remove the directories under ``root`` other than ``keep`` not modified for ``max_age_days``;
    returns those removed. Recent ones stay: another installation may be using them now."""
    removed: list[Path] = []
    if not root.is_dir():
        return removed
    limit = time.time() - max_age_days * 86400.0
    for d in root.iterdir():
        try:
            if d.is_dir() and d != keep and d.stat().st_mtime < limit:
                shutil.rmtree(d, ignore_errors=True)
                removed.append(d)
        except OSError:  # removed meanwhile by another process
            continue
    return removed


#: nodnav's own source directory.
PACKAGE_DIR = Path(__file__).resolve().parent


@functools.lru_cache(maxsize=8)
def kernel_cache_dir(package: Path = PACKAGE_DIR) -> Path:
    """The kernel cache directory of this version of ``package``'s source (by default nodnav's;
    see the module docstring)."""
    root = kernel_cache_root()
    here = root / source_digest(package)[:16]
    if not here.is_dir():
        prune_kernel_dirs(root, here)
    return here


def cached_compiler(package: Path):
    """The decorator :func:`compiled` for the kernels of ``package`` (a directory of source):
    nopython mode, releasing the GIL, cached in :func:`kernel_cache_dir` of ``package``; ``fn``
    unchanged where numba is not installed."""
    try:
        import numba
    except ImportError:  # pragma: no cover - numba is a dependency of the package
        return lambda fn: fn

    def compiled(fn):
        """``fn`` compiled in nopython mode, cached on disk in the source version's directory, releasing the GIL."""
        # numba reads CACHE_DIR when the cache is attached (here, at decoration); it is restored
        # at once, so nothing else in the process caches there.
        saved = numba.config.CACHE_DIR
        numba.config.CACHE_DIR = str(kernel_cache_dir(package))
        try:
            return numba.njit(cache=True, nogil=True)(fn)
        finally:
            numba.config.CACHE_DIR = saved

    return compiled


compiled = cached_compiler(PACKAGE_DIR)
