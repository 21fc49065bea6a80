"""The compiled kernels' disk cache: one directory per version of the package's source, so that a
kernel never runs a stale copy of a kernel of another module that it calls (nodnav.compiled)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from nodnav.compiled import kernel_cache_dir, prune_kernel_dirs, source_digest


def _tree(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    return root


def test_source_digest_changes_with_any_file_and_only_with_content(tmp_path):
    a = _tree(tmp_path / "a", {"x.py": "X = 1\n", "sub/y.py": "Y = 2\n"})
    b = _tree(tmp_path / "b", {"x.py": "X = 1\n", "sub/y.py": "Y = 2\n"})
    assert source_digest(a) == source_digest(b)  # same content elsewhere: same kernels
    (b / "sub" / "y.py").write_text("Y = 3\n")  # a callee's module changed, the caller's not
    assert source_digest(a) != source_digest(b)
    (b / "sub" / "y.py").write_text("Y = 2\n")
    (b / "sub" / "__pycache__").mkdir()
    (b / "sub" / "__pycache__" / "junk.py").write_text("not source\n")
    assert source_digest(a) == source_digest(b)
    (b / "sub" / "y.py").rename(b / "sub" / "z.py")  # a renamed file is another source
    assert source_digest(a) != source_digest(b)


def test_kernels_cache_in_the_directory_of_this_source():
    pytest.importorskip("numba")
    from nodnav.control import braking

    here = kernel_cache_dir()
    assert here.name == source_digest(Path(braking.__file__).resolve().parents[1])[:16]
    assert Path(braking._tail_clearance_kernel._cache._cache_path).is_relative_to(here)
    import numba

    assert numba.config.CACHE_DIR != str(here)  # only nodnav's kernels cache there


def test_the_cache_root_follows_nodnav_then_numba_settings(monkeypatch, tmp_path):
    from nodnav.compiled import kernel_cache_root

    monkeypatch.setenv("NODNAV_CACHE", str(tmp_path / "n"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "m"))
    assert kernel_cache_root() == tmp_path / "n" / "kernels"
    monkeypatch.delenv("NODNAV_CACHE")
    assert kernel_cache_root() == tmp_path / "m" / "nodnav"
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert kernel_cache_root() == Path.home() / ".cache" / "nodnav" / "kernels"


def test_prune_removes_only_old_directories_of_other_versions(tmp_path):
    old, recent, keep = (tmp_path / n for n in ("old", "recent", "keep"))
    for d in (old, recent, keep):
        d.mkdir()
    long_ago = time.time() - 40 * 86400.0
    os.utime(old, (long_ago, long_ago))
    os.utime(keep, (long_ago, long_ago))
    assert prune_kernel_dirs(tmp_path, keep, max_age_days=30.0) == [old]
    assert not old.exists() and recent.exists() and keep.exists()
    assert prune_kernel_dirs(tmp_path / "absent", keep) == []


def test_a_changed_callee_reaches_its_caller(tmp_path):
    """numba alone keeps the caller's cached copy of a callee from another file (the first run
    caches both); nodnav's decorator, on a two-module package of its own (its kernels cached under
    this test's ``NODNAV_CACHE``), compiles the caller again with the new callee."""
    pytest.importorskip("numba")
    pkg = _tree(tmp_path / "src", {
        "pkg/__init__.py": "",
        "pkg/callee.py": "from pkg.jit import compiled\n\n@compiled\ndef f(x):\n    return x + 1.0\n",
        "pkg/caller.py": "from pkg.jit import compiled\nfrom pkg.callee import f\n\n"
                         "@compiled\ndef g(x):\n    return f(x) * 10.0\n",
        "pkg/jit.py": "from pathlib import Path\nfrom nodnav.compiled import cached_compiler\n\n"
                      "compiled = cached_compiler(Path(__file__).resolve().parent)\n",
    }).resolve()
    run = [sys.executable, "-c", "from pkg.caller import g; print(g(1.0))"]
    env = {**os.environ, "PYTHONPATH": f"{pkg}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
           "NODNAV_CACHE": str(tmp_path / "cache")}
    assert subprocess.run(run, capture_output=True, text=True, check=True, env=env).stdout.split() == ["20.0"]
    (pkg / "pkg" / "callee.py").write_text("from pkg.jit import compiled\n\n@compiled\ndef f(x):\n    return x + 2.0\n")
    assert subprocess.run(run, capture_output=True, text=True, check=True, env=env).stdout.split() == ["30.0"]
