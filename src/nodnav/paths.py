"""Where outputs go: file names made from scenario names, and output paths checked before any work.

A command that runs for minutes must not find out at the end that it cannot write its result;
the checks here run first and raise one :class:`~nodnav.errors.NodnavError` line naming the
option (``--out``) and the path.
"""

from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path

from nodnav.errors import NodnavError, shown_path

#: Picture formats the figures can be written in (matplotlib's Agg and vector backends).
FIGURE_FORMATS = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp")

_UNSAFE = re.compile(r"[^A-Za-z0-9._=+-]")


def safe_filename(name: str, limit: int = 100) -> str:
    """``name`` made safe as one file name: characters other than letters, digits and ``._=+-``
    become ``_``, leading dots are dropped (``../escaped`` gives ``_escaped``), at most ``limit``
    characters; never empty."""
    return _UNSAFE.sub("_", str(name)).lstrip(".")[:limit] or "scenario"


def _writable_dir(directory: Path, option: str) -> None:
    """Raise unless a file can be created in the existing directory ``directory``."""
    try:
        fd, probe = tempfile.mkstemp(dir=directory, prefix=".nodnav-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise NodnavError(f"{option}: cannot write in {shown_path(directory)} ({exc.strerror or exc})") from None


def output_dir(path: str | os.PathLike, option: str = "--out") -> Path:
    """The directory ``path``, created if missing, checked to be a directory one can write in."""
    path = Path(path)
    try:
        if path.exists() and not path.is_dir():
            raise NodnavError(f"{option}: {shown_path(path)} exists and is not a directory; give a directory")
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise NodnavError(f"{option}: cannot create the directory {shown_path(path)} "
                          f"({exc.strerror or exc})") from None
    except ValueError:  # a NUL in the name
        raise NodnavError(f"{option}: {shown_path(path)} is not a usable directory name") from None
    _writable_dir(path, option)
    return path


def output_file(path: str | os.PathLike, option: str = "--out", formats: tuple[str, ...] | None = FIGURE_FORMATS,
                default_suffix: str = ".png") -> Path:
    """The file ``path`` checked before anything is computed: not a directory, a known format
    (``formats``; a name without a suffix gets ``default_suffix``, as matplotlib would), its
    directory created if missing and writable. Returns the path that will be written."""
    path = Path(path)
    try:
        if path.is_dir():
            raise NodnavError(f"{option}: {shown_path(path)} is a directory; give a file name such as "
                              f"{shown_path(path / ('name' + default_suffix))}")
        if formats is not None:
            suffix = path.suffix.lower().lstrip(".")
            if not suffix:
                path = path.with_name(path.name + default_suffix)
            elif suffix not in formats:
                raise NodnavError(f"{option}: cannot write .{suffix} pictures; end the file name in one of "
                                  f"{', '.join('.' + f for f in formats)}")
        if path.exists() and not path.is_file():  # a pipe or a device: never a result file
            raise NodnavError(f"{option}: {shown_path(path)} exists and is not a regular file")
        if path.exists() and not os.access(path, os.W_OK):
            raise NodnavError(f"{option}: {shown_path(path)} exists and cannot be overwritten")
        parent = path.parent
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise NodnavError(f"{option}: cannot write {shown_path(path)} ({exc.strerror or exc})") from None
    except ValueError:  # a NUL in the name
        raise NodnavError(f"{option}: {shown_path(path)} is not a usable file name") from None
    _writable_dir(parent, option)
    return path
