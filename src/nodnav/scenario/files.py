"""Reading scenario and study files: YAML parsed with every failure one line, and the built-in scenarios.

A file the user names may be a directory, a pipe, huge, not UTF-8, or YAML that does not parse;
each is one :class:`~nodnav.scenario.fields.ScenarioError` line naming the file.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from nodnav.errors import one_line, shown_path
from nodnav.scenario import limits
from nodnav.scenario.fields import ScenarioError


def builtin_names() -> list[str]:
    """Names of the built-in scenarios, sorted."""
    files = resources.files("nodnav.scenario") / "builtin"
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".yaml"))


def builtin_text(name: str) -> str:
    """The YAML text of the built-in scenario ``name``."""
    return (resources.files("nodnav.scenario") / "builtin" / f"{name}.yaml").read_text()


def read_yaml(path: Path, what: str = "scenario") -> Any:
    """Parse a YAML file the user named, every failure one :class:`ScenarioError` line naming the file.

    Refuses directories, files over :data:`~nodnav.scenario.limits.MAX_FILE_BYTES`, text that is
    not UTF-8, YAML that does not parse, numbers too long to convert, and nesting too deep.
    """
    label = shown_path(path)
    try:
        is_dir, is_file, size = path.is_dir(), path.is_file(), path.stat().st_size
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else "not a usable file name"
        raise ScenarioError(f"{label}: cannot read the {what} file ({reason})", key=str(path)) from None
    if is_dir:
        raise ScenarioError(f"{label}: is a directory; give a {what} YAML file", key=str(path))
    if not is_file:  # a pipe or a device would be read forever
        raise ScenarioError(f"{label}: not a regular file; give a {what} YAML file", key=str(path))
    if size > limits.MAX_FILE_BYTES:
        raise ScenarioError(f"{label}: {size} bytes; a {what} file may have at most {limits.MAX_FILE_BYTES}",
                            key=str(path))
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ScenarioError(f"{label}: cannot read the {what} file ({exc.strerror or exc})", key=str(path)) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{label}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start}); "
                            f"save the {what} file as UTF-8", key=str(path)) from None
    return parse_yaml(text, label)


def parse_yaml(text: str, label: str) -> Any:
    """``yaml.safe_load(text)``, every failure one :class:`ScenarioError` line starting with ``label``."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ScenarioError(f"{label}: {yaml_error_message(exc)}", key=label) from None
    except RecursionError:
        raise ScenarioError(f"{label}: invalid YAML: nested too deeply", key=label) from None
    except (ValueError, OverflowError, TypeError) as exc:  # e.g. an integer of more than 4300 digits
        problem = "a number with more than 4300 digits" if "digits" in str(exc) else one_line(str(exc), 120)
        raise ScenarioError(f"{label}: invalid YAML: {problem}", key=label) from None


def yaml_error_message(exc: yaml.YAMLError) -> str:
    """'invalid YAML at line L, column C: problem', one line, for any YAML parse error."""
    mark = getattr(exc, "problem_mark", None)
    where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return one_line(f"invalid YAML{where}: {problem}", 200)
