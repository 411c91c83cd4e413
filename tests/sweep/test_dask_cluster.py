"""A real dask cluster, started as users start one: ``dask scheduler`` and two ``dask worker``
processes on localhost. A sweep and a load-case table run on it through the ``iceimpact``
command; a worker is killed mid-run (SIGKILL to its process group: nanny and worker, as when a
machine fails) and the tables end complete and equal to serial runs."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from iceimpact.seasons import load_cases, run_season
from iceimpact.sweep import read_table, sweep

DASK = Path(sys.executable).with_name("dask")
GRID = "flow.u=0.05:1.5:24"        # 24 runs of the Figure 2 scene
T_END, DT = 100.0, 2e-3            # s: ~0.2 s per run
CASES = """\
t_end = 100.0
transient = 20.0
repetitions = 3
[defaults]
"drag.model" = 2
[[case]]
name = "slow"
hours = 500.0
"flow.u" = 0.1
[[case]]
name = "medium"
hours = 300.0
"flow.u" = 0.4
"ice.M" = 3200.0
[[case]]
name = "fast"
hours = 100.0
"flow.u" = 1.0
"impact.e" = 0.8
[[case]]
name = "fast, light"
hours = 50.0
"flow.u" = 1.0
"ice.M" = 400.0
"""


def start(cmd: list[str], log: Path, cwd: Path) -> subprocess.Popen:
    """A process in its own session (its group is killed as one: a nanny and its worker)."""
    with open(log, "wb") as fh:
        return subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, cwd=cwd,
                                start_new_session=True)


def kill(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


def rows_in(path: Path) -> int:
    """Complete rows in a table being written (header excluded)."""
    try:
        return max(0, path.read_text().count("\n") - 1)
    except FileNotFoundError:
        return 0


def wait_rows(path: Path, n: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while rows_in(path) < n:
        assert proc.poll() is None, f"the command ended before {n} rows: {proc.returncode}"
        assert time.monotonic() - t0 < timeout, f"no {n} rows in {timeout} s"
        time.sleep(0.02)


def without_wall(rows: list[dict]) -> str:
    """The rows without their wall times, as JSON text: equal values (nan too) give equal text."""
    return json.dumps([{k: v for k, v in r.items() if k != "wall_s"} for r in rows])


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two single-threaded workers; yields (address, [worker A, worker B],
    a function that starts another worker)."""
    if not DASK.exists():
        pytest.skip("dask's command is not installed (pip install 'iceimpact[dask]')")
    scheduler_file = tmp_path / "scheduler.json"
    procs = [start([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0",
                    "--no-dashboard", "--scheduler-file", str(scheduler_file)],
                   tmp_path / "scheduler.log", tmp_path)]

    def worker(name: str) -> subprocess.Popen:
        proc = start([str(DASK), "worker", "--scheduler-file", str(scheduler_file),
                      "--nthreads", "1", "--nworkers", "1", "--no-dashboard", "--name", name,
                      "--death-timeout", "60", "--local-directory", str(tmp_path / name)],
                     tmp_path / f"{name}.log", tmp_path)
        procs.append(proc)
        return proc

    try:
        t0 = time.monotonic()
        while not scheduler_file.exists():
            assert time.monotonic() - t0 < 60, "the scheduler did not start"
            time.sleep(0.05)
        time.sleep(0.2)  # written: read it once complete
        address = json.loads(scheduler_file.read_text())["address"]
        workers = [worker("a"), worker("b")]
        from distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=60)
        yield address, workers, worker
    finally:
        for proc in reversed(procs):
            kill(proc)


def test_sweep_and_load_cases_on_a_cluster_survive_a_killed_worker(cluster, tmp_path):
    address, (worker_a, worker_b), add_worker = cluster
    cli = [sys.executable, "-m", "iceimpact.cli"]

    # a sweep: worker a is killed after 4 runs; dask moves its tasks to worker b
    out = tmp_path / "sweep.csv"
    cmd = [*cli, "sweep", "--vary", GRID, "--t-end", str(T_END), "--dt", str(DT),
           "--out", str(out), "--dask", address, "--quiet"]
    proc = start(cmd, tmp_path / "sweep.log", tmp_path)
    wait_rows(out, 4, proc)
    kill(worker_a)
    assert proc.wait(timeout=300) == 0, (tmp_path / "sweep.log").read_text()
    rows = read_table(out)
    serial = sweep(None, {"flow.u": [r["flow.u"] for r in rows]}, t_end=T_END, dt=DT,
                   workers=1, progress=False)
    assert without_wall(rows) == without_wall(serial)
    # the rerun finds the table complete and leaves it as it is
    before = out.read_bytes()
    assert subprocess.run(cmd, capture_output=True, check=False).returncode == 0
    assert out.read_bytes() == before

    # a load-case table: worker b and the command itself are killed mid-run (the machine the
    # command ran on failed); the rerun, on a new worker, runs only what is missing
    add_worker("c")
    cases = tmp_path / "cases.toml"
    cases.write_text(CASES)
    prefix = tmp_path / "season"
    cmd = [*cli, "loads", str(cases), "--life", "25", "--out", str(prefix), "--dask", address,
           "--quiet"]
    proc = start(cmd, tmp_path / "loads.log", tmp_path)
    table = Path(f"{prefix}.csv")
    wait_rows(table, 3, proc)
    kill(worker_b)
    kill(proc)
    kept = table.read_text().splitlines()[1:]
    assert 3 <= len(kept) < 12
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    final = table.read_text().splitlines()
    assert len(final) == 13
    for line in kept:  # the rows of the killed run are kept as written, wall time included
        assert line in final
    serial_rows, serial_summary = run_season(load_cases(cases), 25.0, workers=1, progress=False)
    assert without_wall(read_table(table)) == without_wall(serial_rows)
    summary = json.loads(Path(f"{prefix}.json").read_text())
    assert summary["lifetime"]["del_1Hz_N"] == serial_summary["lifetime"]["del_1Hz_N"]
