"""Ctrl-C: the command prints one line and exits with 130; its worker processes print nothing,
joblib's resource trackers warn of nothing, and no temporary folder of joblib is left behind."""

import os
import signal
import subprocess
import sys
import time

import pytest

from nodnav.cli.interrupts import QUIET_TRACKERS, quiet_resource_trackers, workers_ignore_interrupts


def _ctrl_c(args, tmp_path, after_bar: float) -> tuple[int, list[str]]:
    """Run ``nodnav ARGS`` in a process group of its own and send the group SIGINT, as a terminal's
    Ctrl-C does, ``after_bar`` seconds after its progress bar appeared; its exit code and stderr lines."""
    env = {**os.environ, "JOBLIB_TEMP_FOLDER": str(tmp_path / "joblib")}
    env.pop("PYTHONWARNINGS", None)
    proc = subprocess.Popen([sys.executable, "-m", "nodnav.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=env, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    err = b""
    while b"%" not in err:  # the progress bar: the workers are being started
        chunk = os.read(proc.stderr.fileno(), 4096)
        if not chunk:
            break
        err += chunk
    time.sleep(after_bar)
    os.killpg(proc.pid, signal.SIGINT)
    _, rest = proc.communicate(timeout=60)  # also waits for the resource trackers, which share stderr
    lines = (err + rest).decode().replace("\r", "\n").splitlines()
    return proc.returncode, [line for line in lines if line.strip() and not line.startswith("roadmaps:")]


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask") or (os.cpu_count() or 1) < 2,
                    reason="needs POSIX signal masks and two cores")
@pytest.mark.parametrize("after_bar", [0.3, 2.0])  # while the workers start up; while they build
def test_interrupted_roadmap_build_prints_one_line(tmp_path, after_bar):
    code, lines = _ctrl_c(["roadmaps", "build", "--robots", "4", "--jobs", "2", "--cache-dir",
                           str(tmp_path / "cache")], tmp_path, after_bar)
    assert (code, lines) == (130, ["nodnav: interrupted"])
    left = list((tmp_path / "joblib").glob("joblib_memmapping_folder_*")) if (tmp_path / "joblib").exists() else []
    assert left == []


@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="needs POSIX signal masks")
def test_processes_started_inside_do_not_see_sigint():
    probe = [sys.executable, "-c",
             "import signal; print(signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []))"]
    with workers_ignore_interrupts():
        inside = subprocess.run(probe, capture_output=True, text=True).stdout.strip()
    outside = subprocess.run(probe, capture_output=True, text=True).stdout.strip()
    assert (inside, outside) == ("True", "False")
    assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])  # this process: as before


def test_tracker_warnings_are_switched_off_once(monkeypatch):
    monkeypatch.setenv("PYTHONWARNINGS", "default::DeprecationWarning")
    quiet_resource_trackers()
    quiet_resource_trackers()
    assert os.environ["PYTHONWARNINGS"] == f"default::DeprecationWarning,{QUIET_TRACKERS}"


def test_a_reader_that_goes_away_is_no_error():
    # nodnav scenarios | head -1: the pipe closes before nodnav writes; nothing on stderr, exit 141 as cat's.
    read, write = os.pipe()
    os.close(read)
    proc = subprocess.run([sys.executable, "-m", "nodnav.cli", "scenarios"], stdout=write, stderr=subprocess.PIPE,
                          text=True, timeout=60)
    os.close(write)
    assert (proc.returncode, proc.stderr) == (141, "")
