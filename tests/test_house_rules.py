"""Rules of the house that no linter checks: no ``type: ignore``, no default standing in for a
declared setting, no exception to the layer contracts."""

import ast
import dataclasses
import inspect
import tomllib
from pathlib import Path

from nodnav.scenario import params

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted((ROOT / "src" / "nodnav").rglob("*.py"))

#: getattr defaults left in place knowingly, as (receiver, setting): remove an entry with its getattr.
KNOWN: set[tuple[str, str]] = set()


def _settings() -> set[str]:
    """The name of every field of every parameter class of a scenario."""
    return {f.name for _, cls in inspect.getmembers(params, inspect.isclass)
            if dataclasses.is_dataclass(cls) and cls.__module__ == params.__name__ for f in dataclasses.fields(cls)}


def test_no_type_ignore():
    found = [f"{p.relative_to(ROOT)}:{k}" for folder in ("src", "tests", "tools", "examples")
             for p in sorted((ROOT / folder).rglob("*.py")) if p.name != Path(__file__).name
             for k, line in enumerate(p.read_text().splitlines(), 1) if "type: ignore" in line]
    assert not found, "type the code instead: " + ", ".join(found)


def test_no_getattr_default_for_a_declared_setting():
    """``getattr(controller, "safety_margin", 0.0)`` gives every implementation without the field
    a silent value: declare the setting on the base parameter class instead (argparse namespaces,
    ``args``, are not parameters)."""
    settings, found = _settings(), []
    for path in SOURCES:
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "getattr"
                    and len(node.args) == 3 and isinstance(node.args[1], ast.Constant)
                    and node.args[1].value in settings):
                receiver = ast.unparse(node.args[0])
                if receiver != "args" and (receiver, node.args[1].value) not in KNOWN:
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    assert not found, found


def test_the_layer_contracts_have_no_exceptions():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    contracts = config["tool"]["importlinter"]["contracts"]
    excepted = [c["name"] for c in contracts if c.get("ignore_imports")]
    assert not excepted, excepted
