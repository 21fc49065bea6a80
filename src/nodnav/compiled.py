"""The decorator of the package's compiled scalar loops.

Hot inner loops (planner timing, roadmap checks, MPC rows, predictions) are written as plain
scalar Python and compiled by numba, cached on disk next to the module. Without numba the same
code runs as Python, slowly but with the same results.
"""

from __future__ import annotations

try:
    from numba import njit as _numba_njit

    def compiled(fn):
        """``fn`` compiled in nopython mode, cached on disk, releasing the GIL."""
        return _numba_njit(cache=True, nogil=True)(fn)
except ImportError:  # pragma: no cover - numba is a dependency of the package
    def compiled(fn):
        """``fn`` unchanged: numba is not installed."""
        return fn
