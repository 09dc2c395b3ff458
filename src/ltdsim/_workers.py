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

Workers are children of the process that made the pool. The model reduction's pool
spawns them (each a fresh interpreter). A sweep's executor forks them where that is safe
(:func:`fork_safe`: Linux, and no other thread running in this process at that moment),
so that they start with the imports and the kernels already loaded here instead of
paying for both again (about 2 s of CPU each); elsewhere it spawns them. With the
workers gone, the resource tracker (started for spawned workers only) reads end-of-file
and exits by itself.

A thread this process runs for itself (the live progress display's redraw) is paused
around the fork: it registers with :func:`pause_for_fork`.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, ExitStack, contextmanager

#: seconds between two looks at the parent's pid in the watcher thread
WATCH_INTERVAL = 0.5
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
#: ``pause()`` context managers of threads this process runs (see :func:`pause_for_fork`)
_PAUSERS: list[Callable[[], AbstractContextManager]] = []


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
    that started it) dies, and give it one BLAS thread (a pool has a worker per core:
    OpenBLAS's own threads in each would only contend for the same cores). Safe to call
    more than once."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")
    _die_with_parent_linux()
    if os.getppid() != parent:  # the parent died before the request above took effect
        os._exit(1)  # noqa: SLF001
    threading.Thread(target=_watch, args=(parent,), name="ltdsim-parent-watch",
                     daemon=True).start()


@contextmanager
def pause_for_fork(pause: Callable[[], AbstractContextManager]) -> Iterator[None]:
    """While open, ``pause()`` (a context manager that stops one of this process's
    threads and starts it again on exit) is entered around every fork of a sweep's
    workers, so that the fork happens with no other thread running."""
    _PAUSERS.append(pause)
    try:
        yield
    finally:
        _PAUSERS.remove(pause)


def fork_safe() -> bool:
    """True where a worker may be forked from this process now: on Linux (where a forked
    child is a copy of this process, imports and compiled kernels included) while no
    Python thread other than this one runs. The native threads numpy's and scipy's
    OpenBLAS keep are not counted: OpenBLAS stops them around a fork itself
    (``pthread_atfork``)."""
    return (sys.platform.startswith("linux")
            and "fork" in multiprocessing.get_all_start_methods()
            and threading.active_count() == 1)


def process_executor(workers: int | None, fork: bool = False) -> cf.ProcessPoolExecutor:
    """A process pool of ``workers`` processes (None: all cores) that end with this
    process. With ``fork``, the workers are forked from this process (their imports and
    the kernels loaded here come with them) when :func:`fork_safe` holds once this
    process's own threads are paused (:func:`pause_for_fork`); they are forked here,
    before this returns. Otherwise they are spawned (fresh interpreters, started when
    work is first submitted)."""
    n = workers or os.cpu_count()
    if fork:
        with ExitStack() as paused:
            for pause in _PAUSERS:
                paused.enter_context(pause())
            if fork_safe():
                ex = cf.ProcessPoolExecutor(max_workers=n,
                                            mp_context=multiprocessing.get_context("fork"),
                                            initializer=init_worker,
                                            initargs=(os.getpid(),))
                # a pool that forks starts all its workers at its first task, and its
                # management thread after them: fork them now, while nothing else runs
                ex.submit(int)
                return ex
    return cf.ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"),
                                  initializer=init_worker, initargs=(os.getpid(),))


def process_pool(workers: int | None):
    """A ``multiprocessing.Pool`` of spawned workers (children of this process, not of a
    fork server; no fork of a process that runs threads) whose workers end with this
    process; ``None`` or -1: all cores. As with every spawned worker, a script that
    uses it runs its work under ``if __name__ == "__main__":``."""
    n = None if workers is None or workers < 0 else workers
    return multiprocessing.get_context("spawn").Pool(
        n, initializer=init_worker, initargs=(os.getpid(),))
