"""Which code produced a result: the package version plus a hash of the code that determines it.

:func:`code_version` is ``<version>+<12 hex digits>``, e.g. ``0.1.0+3f9a2c1b4d5e``. The digits
are the start of a SHA-256 over the files of the installed package that can change a trial's
result: every ``.py`` file and every built-in scenario (``scenario/builtin/*.yaml``), each
hashed with its path relative to the package, in sorted order. Left out are the modules that
only present or orchestrate results (:data:`PRESENTATION`): editing the command line, a
figure or the report does not make stored trials stale. Anything else, a docstring included,
changes the hash. Library versions (NumPy, SciPy, DAQP) are not part of it.

The hash is computed once per process and is the same in every worker process of one
installation.

:func:`numerics` says what else decides a result's last bits: the processor's architecture, the
SIMD extensions NumPy dispatches to on it, NumPy's BLAS and the numerical libraries' versions.
The same code and seed give bitwise the same trial on one machine, whatever the number of
workers; on another processor the small matrix products may round differently (OpenBLAS takes
fused multiply-adds where the processor has them), and the closed loop can carry a last-bit
difference to another outcome (docs/studies.md, "Provenance"). Stored trials and saved
histories record it next to the code version.
"""

from __future__ import annotations

import functools
import hashlib
import platform
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

try:
    PACKAGE_VERSION = version("nodnav")
    """The installed package's version."""
except PackageNotFoundError:  # running from a source tree that is not installed
    PACKAGE_VERSION = "0.0.0"

#: Files (relative to the package, ``/``-separated) and folders (ending in ``/``) that cannot
#: change a trial's result and are left out of the hash.
PRESENTATION = ("cli/", "paths.py", "errors.py", "provenance.py", "viz/", "reporting/",
                "experiments/analysis.py", "experiments/paper.py", "experiments/statistics.py", "experiments/study.py",
                "experiments/sweep.py", "experiments/batch.py", "experiments/store.py", "bench/",
                # the scaling part, which built-ins are the paper's, the bounds' reference page
                "experiments/scaling.py", "scenario/catalogue.py", "scenario/bounds.py")

#: What stored rows written before code versions were recorded hold instead of one.
UNKNOWN = "unknown"


def result_files(root: Path) -> list[Path]:
    """The files under ``root`` (the package directory) whose content determines a trial's result, sorted."""
    files = [p for p in root.rglob("*.py")] + list((root / "scenario" / "builtin").glob("*.yaml"))
    out = []
    for p in files:
        rel = p.relative_to(root).as_posix()
        if "__pycache__" in rel or any(rel == x or (x.endswith("/") and rel.startswith(x)) for x in PRESENTATION):
            continue
        out.append(p)
    return sorted(out, key=lambda p: p.relative_to(root).as_posix())


def source_hash(root: Path) -> str:
    """SHA-256 (hex) over the relative path and bytes of every :func:`result_files` file of ``root``."""
    h = hashlib.sha256()
    for p in result_files(root):
        rel = p.relative_to(root).as_posix().encode()
        data = p.read_bytes()
        h.update(len(rel).to_bytes(4, "little") + rel + len(data).to_bytes(8, "little") + data)
    return h.hexdigest()


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """``<package version>+<first 12 hex digits of source_hash>`` of the installed package."""
    return f"{PACKAGE_VERSION}+{source_hash(Path(__file__).resolve().parent)[:12]}"


def _library_version(name: str) -> str:
    try:
        return version(name)
    except PackageNotFoundError:
        return "absent"


@functools.lru_cache(maxsize=1)
def numerics() -> str:
    """What besides the code decides a result's last bits, in one line: e.g. ``x86_64; NumPy
    2.4.6 SIMD X86_V3+X86_V4+AVX512_ICL; BLAS scipy-openblas 0.3.31; SciPy 1.17.1; DAQP 0.11.0;
    numba 0.68.1`` (once per process)."""
    import numpy as np

    config = getattr(np, "__config__", None)
    info = getattr(config, "CONFIG", {}) if config is not None else {}
    found = info.get("SIMD Extensions", {}).get("found", [])
    blas = info.get("Build Dependencies", {}).get("blas", {})
    blas_name = f"{blas.get('name', 'unknown')} {blas.get('version', '')}".rstrip()
    libraries = "; ".join(f"{label} {_library_version(name)}" for label, name in
                          (("SciPy", "scipy"), ("DAQP", "daqp"), ("numba", "numba")))
    simd = "+".join(found) or "baseline"
    return f"{platform.machine()}; NumPy {np.__version__} SIMD {simd}; BLAS {blas_name}; {libraries}"
