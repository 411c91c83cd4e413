"""The back ends (iceimpact.sweep.backends): a process pool and dask give the serial rows, a
missing dask is a clear error, and a process of many runs keeps its freed memory."""

from __future__ import annotations

import subprocess
import sys

import pytest

from iceimpact.sweep import SweepError, sweep
from sweep_rows import DT, GRID, T_END, TRANSIENT, assert_same_rows


def test_parallel_equals_serial(serial_rows):
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, workers=2, chunksize=1,
                 progress=False)
    assert_same_rows(rows, serial_rows)


def test_dask_equals_serial(serial_rows):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  dashboard_address=None) as cluster:
        rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, progress=False,
                     dask_address=cluster.scheduler_address)
    assert_same_rows(rows, serial_rows)


def test_dask_missing_is_a_clear_error(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_dask(name, *args, **kwargs):
        if name.split(".")[0] in ("dask", "distributed"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    with pytest.raises(SweepError, match=r"pip install 'iceimpact\[dask\]'"):
        sweep(None, {"flow.u": [0.1]}, t_end=T_END, dt=DT, progress=False,
              dask_address="tcp://127.0.0.1:1")


_FAULTS = """
import resource, sys
import numpy as np
from iceimpact.sweep import backends
kept = backends.keep_freed_memory() if sys.argv[1] == "keep" else None
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
a = np.ones(1_000_000)  # 8 MB, as a long run's arrays
del a
before = faults()
for _ in range(20):
    a, b = np.ones(1_000_000), np.ones(1_000_000)
    del a, b
print(kept, faults() - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc")
def test_a_process_of_many_runs_keeps_its_freed_memory():
    """keep_freed_memory (the pool's workers, the command line) has malloc reuse the memory of
    the arrays a run frees: 20 rounds of two 8 MB arrays take some hundreds of page faults (one
    per page would be 80,000); without it, measured, 16,000 to 27,000."""
    def run_with(mode: str) -> tuple[str, int]:
        proc = subprocess.run([sys.executable, "-c", _FAULTS, mode], capture_output=True,
                              text=True, check=True)
        kept, faults = proc.stdout.split()
        return kept, int(faults)
    kept, faults = run_with("keep")
    default_kept, default_faults = run_with("default")
    assert kept == "True" and default_kept == "None"
    assert faults < 2_000 and 5 * faults < default_faults
