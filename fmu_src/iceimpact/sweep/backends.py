"""Where the runs execute: in this process, in a local process pool, or on a dask cluster.
Each back end takes the tasks (chunks of runs, :func:`chunks`) and yields their rows as they
finish.

Pool workers die with the sweep: a worker asks the Linux kernel to kill it when its parent
dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)``), and where that is not available (other systems,
or a worker that is not a direct child, as with the forkserver start method) a watchdog thread
exits the worker as soon as its parent process changes. So a sweep killed with SIGKILL leaves
no workers running; rerunning it resumes from its table.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from .errors import SweepError
from .runner import Task, run_chunk

#: Largest number of runs sent to a worker as one task (progress and resume granularity).
MAX_CHUNK = 8

#: How often (s) a watchdog thread checks that the worker's parent is alive.
WATCHDOG_PERIOD = 0.25

_PR_SET_PDEATHSIG = 1
#: glibc's mallopt parameters (malloc.h) and the values :func:`keep_freed_memory` sets: arrays up
#: to 32 MB (glibc's largest mmap threshold) from malloc's heap, and freed heap memory kept
#: until 1 GB of it lies free at its top
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_MMAP_THRESHOLD, _TRIM_THRESHOLD = 32 * 1024 * 1024, 1024 * 1024 * 1024


def chunks(todo: Sequence[int], points: Sequence[tuple[Any, ...]], workers: int,
           chunksize: int | None) -> list[list[tuple[int, tuple[Any, ...]]]]:
    """Tasks of a few runs each: about 8 tasks per worker (load balance across runs of very
    different cost) and at most :data:`MAX_CHUNK` runs per task (progress and resume
    granularity); the per-task cost of a process pool (~1 ms) is small against a run."""
    if chunksize is None:
        chunksize = max(1, min(MAX_CHUNK, len(todo) // (8 * workers)))
    return [[(i, points[i]) for i in todo[k:k + chunksize]]
            for k in range(0, len(todo), chunksize)]


def serial(tasks: Sequence[Task]) -> Iterator[list[dict[str, Any]]]:
    for task in tasks:
        yield run_chunk(task)


def keep_freed_memory() -> bool:
    """Have glibc's malloc keep the memory this process frees for its next allocations, instead
    of giving it back to the kernel: arrays of up to 32 MB come from its heap, and the heap is
    not trimmed. A run allocates its output arrays afresh (a 600-s run sampled at 2 ms, some
    forty arrays of 2.4 MB), and every page given back and asked for again is a page fault:
    about a third of a season's CPU time without this (``benchmarks/season.py``,
    docs/explanation/speed.md). The process then keeps its peak memory until it ends, so this
    is for processes that run many scenes: the pool's workers and the command line's sweeps
    and seasons call it, and a script of many runs can. Returns whether it applied (False
    where the C library is not glibc)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
        libc.gnu_get_libc_version  # noqa: B018 (glibc's: musl's mallopt does nothing)
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD)
                and mallopt(_M_TRIM_THRESHOLD, _TRIM_THRESHOLD))


def _set_parent_death_signal() -> bool:
    """Linux: SIGKILL this process when the thread that created it exits. False elsewhere."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(ppid: int) -> None:
    """Exit this process (at once, like a kill) when its parent is no longer ``ppid``."""
    stop = threading.Event()
    while not stop.wait(WATCHDOG_PERIOD):
        if os.getppid() != ppid:
            os._exit(1)


def init_worker(parent_pid: int) -> None:
    """Worker initializer. Ctrl-C interrupts the parent, which stops the workers itself (with
    SIGTERM, whose default action is restored in case the parent handles it). The worker dies
    with its parent (see the module docstring); ``parent_pid`` is the sweep's process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    keep_freed_memory()  # (a worker runs many scenes, and ends with the sweep)
    ppid = os.getppid()
    if ppid == parent_pid and _set_parent_death_signal():
        if os.getppid() != parent_pid:  # the parent died before the request took effect
            os._exit(1)
        return
    if ppid != parent_pid and ppid == 1:  # already orphaned (not a forkserver's child)
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(ppid,), name="iceimpact-parent-watchdog",
                     daemon=True).start()


def process_pool(tasks: Sequence[Task], workers: int) -> Iterator[list[dict[str, Any]]]:
    executor = ProcessPoolExecutor(max_workers=workers, initializer=init_worker,
                                   initargs=(os.getpid(),))
    finished = False
    try:
        pending: set[Future] = {executor.submit(run_chunk, task) for task in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                yield future.result()
        finished = True
    finally:
        if finished:
            executor.shutdown(wait=True)
        else:  # interrupted: stop the runs in progress instead of waiting for them
            _terminate_workers(executor)


def _terminate_workers(executor: ProcessPoolExecutor) -> None:
    terminate = getattr(executor, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    # before 3.14: the processes must be taken before shutdown() forgets them
    processes = list((getattr(executor, "_processes", None) or {}).values())
    executor.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()


def dask(tasks: Sequence[Task], address: Any) -> Iterator[list[dict[str, Any]]]:
    """Rows from a dask.distributed cluster; connects now (errors before anything runs)."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError("--dask needs dask.distributed, which is not installed: "
                         "pip install 'iceimpact[dask]'") from None
    own = isinstance(address, str)
    try:
        client = Client(address) if own else address
    except OSError as exc:
        raise SweepError(f"cannot connect to the dask scheduler {address!r}: {exc}") from None

    def batches() -> Iterator[list[dict[str, Any]]]:
        try:
            futures = client.map(run_chunk, list(tasks), pure=False)
            try:
                for future in as_completed(futures):
                    yield future.result()
            finally:
                client.cancel(futures)
        finally:
            if own:
                client.close()

    return batches()
