"""Ctrl-C in a command that runs worker processes: the command answers with one line, and nothing
comes from its workers or from joblib.

A terminal sends Ctrl-C's SIGINT to every process of its foreground group, so the workers that
joblib starts (and their resource trackers) get it too. A worker still starting up (importing
nodnav) then dies with a traceback of its own, and a resource tracker whose process left
temporary folders registered warns about "leaked folder objects" before deleting them. Here the
command alone takes the interrupt: processes started inside :func:`workers_ignore_interrupts`
are born with SIGINT blocked (the mask survives fork and exec; they are stopped by joblib when the
command stops), and the trackers' warnings are switched off (:func:`quiet_resource_trackers`);
the folders themselves are deleted by joblib when the interrupted pool is torn down, or else by
the tracker.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: The warning filter (``PYTHONWARNINGS`` syntax) that silences joblib's and multiprocessing's
#: resource trackers: every warning they give starts with "resource_tracker:".
QUIET_TRACKERS = "ignore:resource_tracker:UserWarning"

_receiver: threading.Thread | None = None


def quiet_resource_trackers() -> None:
    """Silence the resource trackers' warnings in every process started from now on (a tracker is
    a process of its own, which reads ``PYTHONWARNINGS`` when it starts)."""
    current = [f for f in os.environ.get("PYTHONWARNINGS", "").split(",") if f]
    if QUIET_TRACKERS not in current:
        os.environ["PYTHONWARNINGS"] = ",".join(current + [QUIET_TRACKERS])


def _start_receiver() -> None:
    """A thread that never blocks SIGINT, so that the process still receives it while the main
    thread blocks it; Python then raises KeyboardInterrupt in the main thread as always."""
    global _receiver
    if _receiver is None or not _receiver.is_alive():
        _receiver = threading.Thread(target=threading.Event().wait, name="nodnav-sigint", daemon=True)
        _receiver.start()


def _start_trackers() -> None:
    """Start the resource trackers now: starting one later would unblock SIGINT in the thread
    that starts it (Python 3.11's ``multiprocessing.resource_tracker`` does so unconditionally)."""
    from multiprocessing import resource_tracker

    from joblib.externals.loky.backend import resource_tracker as loky_tracker

    resource_tracker.ensure_running()
    loky_tracker.ensure_running()


@contextmanager
def workers_ignore_interrupts() -> Iterator[None]:
    """Within this block, processes started by this process never see SIGINT; the command does.

    The main thread blocks SIGINT (a mask that processes it starts inherit), while a helper
    thread, started before, leaves it unblocked to receive it. Outside the main thread, or
    where signal masks do not exist, this does nothing.
    """
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    _start_receiver()
    _start_trackers()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
