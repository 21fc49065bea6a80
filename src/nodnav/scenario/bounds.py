"""Every bound of a scenario, read from where it is declared, and the reference page generated from them.

A number's accepted range is declared once, on its parameter field
(``metadata=accepted(...)``, :func:`~nodnav.scenario.limits.accepted`), and the size limits are
the ``MAX_*`` constants of :mod:`nodnav.scenario.limits`. :func:`declared_ranges` collects the
ranges by key path (``planner.dt``); :func:`reference_page` renders both as the Markdown page
``docs/reference-bounds.md`` (``tools/reference_bounds.py`` writes it, and a test checks that the
page in the repository is what the code declares).
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import re
import textwrap
import typing
from typing import Any

from nodnav.scenario import limits
from nodnav.scenario.fields import field_range
from nodnav.scenario.limits import Range
from nodnav.scenario.params import (
    BaselineParams,
    ControllerParams,
    ExecutionParams,
    FastPlannerParams,
    MPCParams,
    OpinionParams,
    PlannerParams,
    PRMParams,
    RobotSpec,
    SensingParams,
    SimParams,
)
from nodnav.scenario.schema import Scenario

#: The parameter classes of a scenario by section of the file (``""``: the top level), each with
#: the name of the implementation it belongs to (``""``: every one of the section).
SECTIONS: tuple[tuple[str, tuple[tuple[type, str], ...]], ...] = (
    ("opinion", ((OpinionParams, ""),)),
    ("robots", ((RobotSpec, ""),)),
    ("planner", ((PlannerParams, ""), (FastPlannerParams, "fast"), (PRMParams, "prm"))),
    ("controller", ((ControllerParams, ""), (MPCParams, "mpc"))),
    ("sim", ((SimParams, ""),)),
    ("execution", ((ExecutionParams, ""),)),
    ("baselines", ((BaselineParams, ""),)),
    ("sensing", ((SensingParams, ""),)),
    ("", ((Scenario, ""),)),
)


@dataclasses.dataclass(frozen=True)
class Bound:
    """One declared range: where it is written in a scenario file and what it accepts."""

    key: str
    """Key path in a scenario file (``planner.dt``; ``robots.radius`` for every robot and ``robot_defaults``)."""
    bound: Range
    """The accepted range ``(least, greatest, least_included)``."""
    owner: str
    """The implementation the field belongs to (``fast``, ``prm``, ``mpc``), empty for all."""
    each: bool
    """Whether the range applies to each number of a list or mapping."""
    why: str
    """The reason or the rule between fields that goes with the range, if any."""
    what: str
    """The field's docstring."""


def _is_collection(hint: Any) -> bool:
    return typing.get_origin(hint) in (tuple, dict)


def declared_bounds() -> list[Bound]:
    """Every declared range of the built-in parameter classes, in the order of :data:`SECTIONS`
    and of the fields; a field that several classes of a section share is listed once."""
    out: list[Bound] = []
    seen: dict[str, Range] = {}
    for section, classes in SECTIONS:
        for cls, owner in classes:
            docs = field_docstrings(cls)
            hints = typing.get_type_hints(cls)
            for f in dataclasses.fields(cls):
                bound = field_range(f)
                key = f"{section}.{f.name}" if section else f.name
                if bound is None or key in seen:
                    if bound is not None and seen[key] != bound:
                        raise ValueError(f"{key}: {cls.__name__} declares {bound}, another class {seen[key]}")
                    continue
                seen[key] = bound
                out.append(Bound(key, bound, owner, _is_collection(hints[f.name]), f.metadata.get("why", ""),
                                 docs.get(f.name, "")))
    return out


def declared_ranges() -> dict[str, Range]:
    """The accepted range of every number of a scenario by key path, as :func:`declared_bounds`."""
    return {b.key: b.bound for b in declared_bounds()}


def field_docstrings(cls: type) -> dict[str, str]:
    """The docstrings written under the fields of the class ``cls`` (and of its bases), by field name."""
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if klass is object or not dataclasses.is_dataclass(klass):
            continue
        body = ast.parse(textwrap.dedent(inspect.getsource(klass))).body[0]
        assert isinstance(body, ast.ClassDef)
        for stmt, after in zip(body.body, body.body[1:]):
            if (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name)
                    and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                    and isinstance(after.value.value, str)):
                out[stmt.target.id] = " ".join(after.value.value.split())
    return out


def limit_docstrings() -> dict[str, str]:
    """The docstrings of the ``MAX_*`` constants of :mod:`nodnav.scenario.limits`, by name."""
    body = ast.parse(inspect.getsource(limits)).body
    out = {}
    for stmt, after in zip(body, body[1:]):
        if (isinstance(stmt, ast.Assign) and len(stmt.targets) == 1 and isinstance(stmt.targets[0], ast.Name)
                and stmt.targets[0].id.startswith("MAX_") and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str)):
            out[stmt.targets[0].id] = " ".join(after.value.value.split())
    return out


def _number(x: float) -> str:
    return re.sub(r"e([+-])0*(\d)", lambda m: f"e{'-' if m.group(1) == '-' else ''}{m.group(2)}", f"{x:g}")


def interval(bound: Range) -> str:
    """A range as an interval, ``[0.01, 1]``, ``(0, 2]`` or ``[-1e6, 1e6]``."""
    low, high, closed = bound
    return f"{'[' if closed else '('}{_number(low)}, {_number(high)}]"


_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")


def markdown(text: str) -> str:
    """A docstring's reStructuredText markup as Markdown: ````x```` and ``:mod:`a.b``` as code."""
    text = _ROLE.sub(lambda m: f"`{m.group(1)}`", text)
    return text.replace("``", "`").replace("|", "\\|")


def _first_sentence(text: str) -> str:
    end = re.search(r"\.(\s+[A-Z]|$)", text)
    return text[:end.start() + 1] if end else text


def reference_page() -> str:
    """The Markdown page of every bound of a scenario (``docs/reference-bounds.md``)."""
    lines = [
        "# Bounds of a scenario",
        "",
        "<!-- Generated by tools/reference_bounds.py from the code (nodnav.scenario.bounds); do not edit. -->",
        "",
        "A scenario is checked once, when it is loaded; a number outside its range is refused with one",
        "line naming the key and the range. Each range is declared on its parameter field",
        "(`metadata=accepted(low, high, low_included)` in `nodnav/scenario/params.py`, the same",
        "`metadata={\"range\": (low, high, low_included)}` a plugin's parameters declare), and this page is",
        "generated from those declarations. `robots.*` applies to `robot_defaults` and to every robot;",
        "a list's or a mapping's range applies to each of its numbers. Rules between keys (a corridor",
        "wide enough for every robot, `controller.dt` at most `controller.horizon`, ...) are checked in",
        "`nodnav/scenario/schema.py`.",
        "",
        "## Ranges",
        "",
        "| key | accepted | rule or reason | what it is |",
        "|---|---|---|---|",
    ]
    for b in declared_bounds():
        key = f"`{b.key}`" + (f" ({b.owner})" if b.owner else "")
        accepted = ("each in " if b.each else "") + interval(b.bound)
        lines.append(f"| {key} | {accepted} | {markdown(b.why)} | {markdown(b.what)} |")
    lines += ["", "## Size limits", "", "| limit | value | what it is |", "|---|---|---|"]
    for name, doc in limit_docstrings().items():
        value = getattr(limits, name)
        shown = f"{value:,}" if isinstance(value, int) else f"{value:g}"
        lines.append(f"| `{name}` | {shown} | {markdown(_first_sentence(doc))} |")
    return "\n".join(lines) + "\n"
