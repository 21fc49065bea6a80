"""A sweep on a local Dask cluster (scheduler and two worker processes on 127.0.0.1) stores what a local run stores."""

import os
import signal
import subprocess
import sys
import threading

import pytest

from nodnav.errors import NodnavError
from nodnav.experiments.batch import run_sweep
from nodnav.experiments.store import ResultStore
from nodnav.experiments.study import SweepSpec

pytest.importorskip("distributed")

# Worker processes re-import the main module, so the cluster runs as a script with a main guard.
CLUSTER = """
import sys
from distributed import LocalCluster

if __name__ == "__main__":
    with LocalCluster(host="127.0.0.1", n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        print(cluster.scheduler_address, flush=True)
        sys.stdin.read()  # serve until the test closes our standard input
"""


@pytest.fixture
def scheduler(tmp_path):
    script = tmp_path / "cluster.py"
    script.write_text(CLUSTER)
    with open(tmp_path / "cluster.log", "w") as log:
        proc = subprocess.Popen([sys.executable, str(script)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=log, text=True, start_new_session=True)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.append(proc.stdout.readline().strip()), daemon=True)
    reader.start()
    reader.join(timeout=60)
    try:
        assert lines and lines[0].startswith("tcp://127.0.0.1:"), (tmp_path / "cluster.log").read_text()
        yield lines[0]
    finally:
        proc.stdin.close()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _results(db):
    with ResultStore(db) as store:
        return {r.key: (r.outcome, r.error, r.metrics, {k: v for k, v in r.summary.items() if k != "wall_time_s"})
                for r in store.records()}


def test_dask_cluster_stores_the_same_results_as_a_local_run(tmp_path, scheduler):
    spec = SweepSpec(name="dask", scenarios=("2r-case1",), trials=2)
    on_cluster = run_sweep(spec, tmp_path / "dask.sqlite", scheduler=scheduler, quiet=True)
    local = run_sweep(spec, tmp_path / "local.sqlite", jobs=1, quiet=True)
    assert on_cluster.done == local.done == 2 and on_cluster.errors == local.errors == 0
    assert _results(tmp_path / "dask.sqlite") == _results(tmp_path / "local.sqlite")
    again = run_sweep(spec, tmp_path / "dask.sqlite", scheduler=scheduler, quiet=True)
    assert (again.done, again.skipped) == (0, 2)


def test_an_address_without_a_scheduler_is_a_one_line_error(tmp_path):
    import socket

    with socket.socket() as s:  # a port on which nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    spec = SweepSpec(name="nowhere", scenarios=("2r-case1",), trials=1)
    with pytest.raises(NodnavError, match=f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}") as info:
        run_sweep(spec, tmp_path / "r.sqlite", scheduler=f"tcp://127.0.0.1:{port}", quiet=True,
                  connect_timeout=2.0)
    assert "\n" not in str(info.value)
