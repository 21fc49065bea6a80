"""The report being written: its markdown lines, figures, generated readings and missing studies."""

from __future__ import annotations

from pathlib import Path

from nodnav.experiments.store import ResultStore
from nodnav.reporting.markdown import produced


class ReportDocument:
    """Collects the markdown, figures and readings of one report; every section writes into it."""

    def __init__(self, store: ResultStore, out: Path, command: str):
        self.store, self.out, self.command = store, out, command
        self.lines: list[str] = []
        self.figures: list[Path] = []
        self.missing: list[str] = []
        self.notes: list[str] = []
        self.studies = store.studies()

    def add(self, *lines: str) -> None:
        """Append markdown lines."""
        self.lines.extend(lines)

    def read(self, sentences: list[str]) -> None:
        """Append a section's generated reading, one bullet per sentence."""
        self.notes.extend(sentences)
        self.add("", "**Reading (generated from the numbers above).**", "")
        self.add(*(f"- {s}" for s in sentences))
        self.add("")

    def figure(self, path: Path, alt: str, source: str) -> None:
        """Include a figure written into the output directory, with the line saying what produced it."""
        self.figures.append(path)
        self.add("", f"![{alt}]({path.name})", "", produced(self.command, source), "")

    def absent(self, study: str, how: str) -> None:
        """Say that ``study`` is not in the database and ``how`` to add it."""
        self.missing.append(study)
        self.add("", f"Not in this database: no trials of study `{study}`. {how}", "")

    def has(self, study: str) -> bool:
        """Whether the database holds trials of ``study``."""
        return self.store.count(study) > 0
