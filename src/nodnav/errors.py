"""Errors that reach the user as one line: what is wrong and how to fix it.

Whatever a user typed may be huge (a 5000-digit number), deeply nested, or hold line breaks;
:func:`shown` quotes it in a message bounded in length and on one line, and :func:`one_line`
is the command line's last guard that every message it prints is one line.
"""

from __future__ import annotations

import difflib
import reprlib
from collections.abc import Iterable

#: Longest message the command line prints (characters); anything beyond is cut with "...".
MAX_MESSAGE = 600


class NodnavError(Exception):
    """Base of every error the command line reports as a single line."""


class _Quote(reprlib.Repr):
    """``repr`` bounded in size and depth, and safe for integers too long to print."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict, self.maxset = 2, 4, 4, 4, 4
        self.maxstring, self.maxother, self.maxlong = 40, 40, 30

    def repr_int(self, x: int, level: int) -> str:
        # Python refuses to print integers of more than 4300 digits; their length is what matters.
        if abs(x) >= 10 ** 30:
            return f"{'-' if x < 0 else ''}<a {int(x.bit_length() * 0.30103) + 1}-digit integer>"
        return repr(x)

    def repr_instance(self, x, level: int) -> str:
        try:
            return super().repr_instance(x, level)
        except Exception:  # a broken __repr__ must not break the message about it
            return f"<{type(x).__name__}>"


_QUOTE = _Quote()


def shown(value) -> str:
    """``value`` as it should appear in a one-line message: ``repr`` bounded in length and depth."""
    try:
        return _QUOTE.repr(value)
    except Exception:  # pragma: no cover - reprlib guards every builtin; this is for odd objects
        return f"<{type(value).__name__}>"


def one_line(text: object, limit: int = MAX_MESSAGE) -> str:
    """``text`` (or an exception's message) with every run of whitespace (line breaks included)
    made one space, cut to ``limit``."""
    flat = " ".join(str(text).split())
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


def shown_path(path) -> str:
    """A file name as typed when it is one line of printable text of reasonable length, else :func:`shown`."""
    text = str(path)
    return text if text.isprintable() and 0 < len(text) <= 300 else shown(text)


def nearest_hint(key: object, valid: Iterable[str], what: str = "valid keys") -> str:
    """'; did you mean X?' for the closest valid name, else the list of valid names."""
    valid = list(valid)
    match = difflib.get_close_matches(str(key)[:100], valid, n=1, cutoff=0.5) if isinstance(key, str) else []
    return f"; did you mean '{match[0]}'?" if match else f"; {what}: {', '.join(sorted(valid))}"
