"""The code base passes its linters: ruff (style, import order, bugbear), mypy, and the import
contracts that keep the layers pointing down (import-linter), all configured in pyproject.toml."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent


def _tool(name: str) -> str:
    path = BIN / name
    if path.exists():
        return str(path)
    found = shutil.which(name)
    if found is None:
        pytest.fail(f"{name} is not installed: pip install -e '.[dev]'")
    return found


def _run(*command: str) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600)


def test_ruff_is_clean():
    done = _run(_tool("ruff"), "check", "src", "tests", "examples", "tools")
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-2000:]


def test_mypy_is_clean():
    done = _run(_tool("mypy"))
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-2000:]


def test_layers_only_point_down_and_nothing_cycles():
    done = _run(_tool("lint-imports"))
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-2000:]
