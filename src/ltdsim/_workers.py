"""Worker processes that end with the process that started them.

A sweep's (and the model reduction's) worker processes wait on a queue for work. When
the process that started them dies without closing the pool (SIGKILL, the OOM killer,
a crash), nothing wakes them: each holds both ends of its own task pipe, so it never
sees end-of-file, and it stays alive with its numba kernels loaded (about 250 MB). The
multiprocessing resource tracker then stays too, because every worker holds the write
end of the tracker's pipe and the tracker only exits when the last writer is gone.

Every worker therefore runs :func:`init_worker` first:

* on Linux it asks the kernel to send it SIGKILL when its parent dies
  (``prctl(PR_SET_PDEATHSIG)``), then checks that the parent has not already died
  before that took effect;
* everywhere, a daemon thread polls the parent's pid and ends the process when it
  changes (the process was re-parented: its parent is gone). The thread runs when the
  worker holds no lock on the interpreter, i.e. between compiled kernel calls.

Both pools spawn their workers (children of the process that made the pool). With the
workers gone, the resource tracker reads end-of-file and exits by itself.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import signal
import sys
import threading
import time

#: seconds between two looks at the parent's pid in the watcher thread
WATCH_INTERVAL = 0.5
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _die_with_parent_linux() -> bool:
    """Ask Linux to SIGKILL this process when its parent dies; False if not possible."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent: int) -> None:
    while True:
        time.sleep(WATCH_INTERVAL)
        if os.getppid() != parent:
            os._exit(1)  # noqa: SLF001 - no cleanup to do: the parent writes every result


def init_worker(parent: int) -> None:
    """Initializer of a worker process: end it when ``parent`` (the pid of the process
    that started it) dies. Safe to call more than once."""
    _die_with_parent_linux()
    if os.getppid() != parent:  # the parent died before the request above took effect
        os._exit(1)  # noqa: SLF001
    threading.Thread(target=_watch, args=(parent,), name="ltdsim-parent-watch",
                     daemon=True).start()


def process_executor(workers: int | None) -> cf.ProcessPoolExecutor:
    """A process pool (spawned workers) whose workers end with this process."""
    ctx = multiprocessing.get_context("spawn")
    return cf.ProcessPoolExecutor(max_workers=workers or os.cpu_count(), mp_context=ctx,
                                  initializer=init_worker, initargs=(os.getpid(),))


def process_pool(workers: int | None):
    """A ``multiprocessing.Pool`` of spawned workers (children of this process, not of a
    fork server; no fork of a process that runs threads) whose workers end with this
    process; ``None`` or -1: all cores. As with every spawned worker, a script that
    uses it runs its work under ``if __name__ == "__main__":``."""
    n = None if workers is None or workers < 0 else workers
    return multiprocessing.get_context("spawn").Pool(
        n, initializer=init_worker, initargs=(os.getpid(),))
