"""Markdown pieces the report is written with."""

from __future__ import annotations


def md_table(header: list[str], rows: list[list]) -> list[str]:
    """A markdown table's lines: the header, the rule, one line per row (cells as text)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return lines + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]


def produced(command: str, source: str) -> str:
    """The italic line under a figure or table saying which command produced it, from what."""
    return f"*Produced by `{command}` {source}.*"
