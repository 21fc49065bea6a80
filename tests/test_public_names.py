"""The package root's public names: declared once (the imports under ``TYPE_CHECKING`` in
``nodnav/__init__.py``), each importable, and listed alike by ``__all__``, ``dir(nodnav)`` and the
table that loads them lazily."""

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

import nodnav


def _imports_for_type_checkers() -> dict[str, tuple[str, str]]:
    """What a type checker sees: every ``from M import A as B`` under ``if TYPE_CHECKING:``."""
    tree = ast.parse(Path(nodnav.__file__).read_text())
    blocks = [n for n in tree.body if isinstance(n, ast.If) and isinstance(n.test, ast.Name)
              and n.test.id == "TYPE_CHECKING"]
    assert len(blocks) == 1
    return {a.asname or a.name: (n.module, a.name) for n in blocks[0].body for a in n.names}


def test_all_dir_and_the_lazy_table_list_the_same_names():
    declared = _imports_for_type_checkers()
    assert nodnav._HOMES == declared
    assert sorted(nodnav.__all__) == sorted([*declared, "__version__"])
    assert len(set(nodnav.__all__)) == len(nodnav.__all__)
    assert dir(nodnav) == sorted(nodnav.__all__)  # dir() sorts what __dir__ returns


@pytest.mark.parametrize("name", sorted(_imports_for_type_checkers()))
def test_every_declared_name_imports_as_what_it_is_declared_to_be(name):
    module, attr = _imports_for_type_checkers()[name]
    assert getattr(nodnav, name) is getattr(importlib.import_module(module), attr)


def test_registries_come_with_their_built_in_implementations():
    """In a fresh interpreter, ``nodnav.PLANNERS`` alone lists the built-ins (their layer is imported)."""
    code = ("import nodnav; print(','.join(nodnav.PLANNERS.names()), ','.join(nodnav.CONTROLLERS.names()), "
            "'nod' in nodnav.METHODS.names())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[0].split(",")[:2] == ["fast", "prm"] and out[1].split(",")[0] == "mpc" and out[2] == "True"


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="has no attribute 'run_trail'"):
        nodnav.run_trail  # noqa: B018
    with pytest.raises(ImportError):
        exec("from nodnav import run_trail", {})


def test_running_a_trial_through_the_api_does_not_load_the_plotting_library(tmp_path):
    """``from nodnav import run_trial`` loads no matplotlib (the report's modules need it, the
    closed loop does not: 0.3 s and 45,000 objects per process, docs/performance-6.md),
    and ``nodnav.build_report`` still builds reports (loading it then)."""
    code = ("import sys; from nodnav import load_scenario, run_trial; "
            "assert 'matplotlib' not in sys.modules, 'matplotlib loaded'; "
            "import nodnav; r = nodnav.build_report(sys.argv[1], sys.argv[2]); "
            "assert not r.success and 'no such results database' in r.reason, r.reason")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "none.sqlite"), str(tmp_path / "out")],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
