"""Exports of a recorded trial to the tools users have: CSV and Parquet for pandas, ROS 2 bags for RViz.

A layer of its own above the simulation (beside :mod:`nodnav.viz` and :mod:`nodnav.reporting`):
:func:`export_history` reads a history file (``nodnav run SCENARIO --out DIR`` writes one),
replays the trial for its plans (:mod:`nodnav.export.plans`), and writes one of
:data:`FORMATS`: :mod:`nodnav.export.tables` (``csv``, ``parquet``: one row per robot and
control step) or :mod:`nodnav.export.rosbag` (``rosbag2``: poses and plans per robot). The
libraries are the extra ``nodnav[export]`` (pandas, pyarrow, rosbags).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from nodnav.errors import NodnavError, shown_path
from nodnav.sim.history import History

#: Export format -> the Python modules it needs (all in ``nodnav[export]``).
FORMATS = {"csv": ("pandas",), "parquet": ("pandas", "pyarrow"), "rosbag2": ("rosbags",)}


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote."""

    success: bool
    """Whether the file (or bag directory) was written."""
    reason: str
    """One line: what was written, and whether the plans are in it."""
    path: Path
    """The file or bag directory written."""
    counts: dict[str, int] = field(default_factory=dict)
    """Rows (tables) or messages per topic (bags)."""


def missing_libraries(fmt: str) -> list[str]:
    """The modules format ``fmt`` needs that are not installed."""
    import importlib.util

    return [m for m in FORMATS[fmt] if importlib.util.find_spec(m) is None]


def check_format(fmt: str) -> None:
    """An unknown format, or one whose libraries are missing, is one :class:`NodnavError` line."""
    if fmt not in FORMATS:
        raise NodnavError(f"--format: unknown format {fmt!r}; give one of {', '.join(FORMATS)}")
    missing = missing_libraries(fmt)
    if missing:
        raise NodnavError(f"--format {fmt}: needs {', '.join(missing)}: pip install 'nodnav[export]'")


def export_history(history: History, fmt: str, out: str | Path, plans: bool = True) -> ExportResult:
    """Write ``history`` as ``fmt`` (:data:`FORMATS`) to ``out`` (a file; for ``rosbag2`` a new
    directory). With ``plans`` the trial is replayed for the plans (seconds to a minute)."""
    from nodnav.export.plans import replay_plans

    check_format(fmt)
    out = Path(out)
    replayed = replay_plans(history) if plans else None
    note = ("with plans" if replayed is not None and replayed.success
            else "without plans (--no-plans)" if replayed is None else f"without plans: {replayed.reason}")
    if fmt == "rosbag2":
        from nodnav.export.rosbag import write_bag

        if out.exists():
            raise NodnavError(f"--out: {shown_path(out)} exists; a bag is a new directory (remove it or give another)")
        counts = write_bag(history, replayed, out)
        return ExportResult(True, f"wrote {out}: {sum(counts.values())} messages on {len(counts)} topics, {note}",
                            out, counts)
    from nodnav.export.tables import trial_frame, write_csv, write_parquet

    frame = trial_frame(history, replayed)
    (write_csv if fmt == "csv" else write_parquet)(frame, out)
    return ExportResult(True, f"wrote {out}: {len(frame)} rows (robots x steps), {len(frame.columns)} columns, {note}",
                        out, {"rows": len(frame)})
