"""Progress of long work on stderr: a live display on a terminal, timestamped lines in a log.

rich's live progress redraws one block of the terminal; written to a file or a pipe it
prints nothing until the end. When the console is not a terminal, :class:`Display`
prints plain lines instead: one when a stage starts or ends, and one at most every
``interval`` seconds while it runs ("12:03:41 sweep: 5/16 cases, 12 s").
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager

from rich.console import Console
from rich.markup import escape
from rich.progress import (BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn,
                           TimeRemainingColumn)
from rich.text import Text

#: what the compile line says (the kernels are kept in numba's cache afterwards)
COMPILING = "compiling (first run only)"
#: seconds between two redraws of the live display (rich's default: 10 per second)
REDRAW_INTERVAL = 0.1


def remaining(seconds: float) -> str:
    """A time left in words: ``45 s``, ``12 min``, ``3.5 h``."""
    if seconds < 60.0:
        return f"{seconds:.0f} s"
    if seconds < 3600.0:
        return f"{seconds / 60.0:.0f} min"
    return f"{seconds / 3600.0:.1f} h"


class _Remaining(TimeRemainingColumn):
    """Time remaining, blank for tasks without a known total (compile, stages)."""

    def render(self, task):
        return Text("") if task.total is None or task.finished else super().render(task)


class Display:
    """Progress of a command on ``console`` (stderr).

    Use as a context manager; feed it from the library's callbacks:

    * :meth:`compiling` is a :func:`ltdsim.engine.warmup.warm_up` tick;
    * :meth:`bar` starts a counted task (simulated seconds, cases) and returns its
      ``update(done)`` callback;
    * :meth:`stage` reports a stage and a message (``ltdsim study``);
    * :meth:`note` prints a line that must be read (damaged state being recomputed).

    Nothing is shown when ``quiet``.

    The live display is redrawn by a thread of its own (not rich's), which stops while
    a sweep forks its workers (:func:`ltdsim._workers.pause_for_fork`): a process is
    forked only while no other thread runs in it.
    """

    def __init__(self, console: Console, *, quiet: bool = False, interval: float = 10.0):
        self.console = console
        self.quiet = quiet
        self.interval = interval
        self.live = console.is_terminal and not quiet
        self._lock = threading.Lock()
        self._progress = None
        self._compile_task: TaskID | None = None
        self._stage_task: TaskID | None = None
        self._stage = None
        self._stage_t0 = 0.0
        self._pending = None  # the stage's latest message, when not yet in the log
        self._last_line = {}  # key -> time of its last log line
        self._running = {}  # bar -> writes its line again (log mode, between updates)
        self._redraw: tuple[threading.Thread, threading.Event] | None = None
        self._stack = ExitStack()

    # ------------------------------------------------------------------ plumbing
    def __enter__(self) -> Display:
        from ltdsim._workers import pause_for_fork

        if self.live:
            self._progress = Progress(
                TextColumn("[bold]{task.description}"), BarColumn(bar_width=20),
                TextColumn("{task.fields[info]}"), TimeElapsedColumn(), _Remaining(),
                console=self.console, transient=False, auto_refresh=False)
            self._progress.__enter__()
        if self.live or (not self.quiet and self.interval > 0.0):
            # a terminal is redrawn; a log gets a running task's line every interval
            # even while nothing reports (a sweep's long case, a slow stage)
            self._start_redraw()
            self._stack.enter_context(pause_for_fork(self._paused))
        return self

    def __exit__(self, *exc) -> None:
        self._stack.close()
        self._stop_redraw()
        if self._progress is not None:
            self._progress.__exit__(*exc)

    def _start_redraw(self) -> None:
        stop = threading.Event()

        def redraw():
            while not stop.wait(REDRAW_INTERVAL if self.live else
                                min(1.0, self.interval)):
                if self.live:
                    self._progress.refresh()
                else:
                    self._heartbeat()

        thread = threading.Thread(target=redraw, name="ltdsim-progress-redraw", daemon=True)
        self._redraw = (thread, stop)
        thread.start()

    def _stop_redraw(self) -> None:
        if self._redraw is not None:
            thread, stop = self._redraw
            stop.set()
            thread.join()
            self._redraw = None

    @contextmanager
    def _paused(self) -> Iterator[None]:
        """No redraw thread while open (a sweep forks its workers meanwhile)."""
        running = self._redraw is not None
        self._stop_redraw()
        try:
            yield
        finally:
            if running:
                self._start_redraw()

    def log(self, text: str) -> None:
        """One timestamped line (log mode only)."""
        if self.quiet or self.live:
            return
        with self._lock:
            self.console.print(f"{time.strftime('%H:%M:%S')} {text}", markup=False,
                               highlight=False, soft_wrap=True)

    def note(self, text: str) -> None:
        """A line that must be read (e.g. "recomputing case g0001: ..."): printed above
        the live display on a terminal, timestamped in a log; also when ``quiet``."""
        if self.live:
            self._progress.console.print(text, markup=False, highlight=False, soft_wrap=True)
            return
        with self._lock:
            self.console.print(f"{time.strftime('%H:%M:%S')} {text}", markup=False,
                               highlight=False, soft_wrap=True)

    def info(self, text: str) -> None:
        """A line worth reading before long work starts (a run's estimate): above the
        live display on a terminal, timestamped in a log; nothing when ``quiet``."""
        if not self.quiet:
            self.note(text)

    def _heartbeat(self) -> None:
        """In a log: the latest state of every running bar whose last line is older than
        ``interval`` (its time and time left as of now)."""
        for key, again in list(self._running.items()):
            if self._due(key):
                again()

    def _due(self, key: str, force: bool = False) -> bool:
        now = time.monotonic()
        last = self._last_line.get(key)
        if force or last is None or now - last >= self.interval:
            self._last_line[key] = now
            return True
        return False

    # ------------------------------------------------------------------ callbacks
    def compiling(self, elapsed: float, done: bool) -> None:
        """Tick of :func:`ltdsim.engine.warmup.warm_up`: a compile started, runs or ended."""
        if self.live:
            prog = self._progress
            if self._compile_task is None:
                self._compile_task = prog.add_task(COMPILING, total=None, info="")
            if done:
                prog.update(self._compile_task, total=1, completed=1, info="done")
            return
        if done:
            self.log(f"compiled in {elapsed:.0f} s (kept in the cache for later runs)")
        elif elapsed == 0.0:
            self._due("compile", force=True)
            self.log(f"{COMPILING}: the kernels are compiled once and kept for later runs")
        elif self._due("compile"):
            self.log(f"{COMPILING}: {elapsed:.0f} s")

    def bar(self, description: str, total: float, unit: str,
            fmt: str = "{:.0f}") -> Callable[[float], None]:
        """A counted task ("s simulated", "cases" as ``unit``); returns ``update(done)``.
        The task appears at its first update."""
        t0 = None
        task = None

        def info(done):
            return f"{fmt.format(done)}/{fmt.format(total)} {unit}"

        def line(done: float, first: bool) -> None:
            spent = time.monotonic() - t0
            took = "" if first else f", {spent:.0f} s"
            if not first and 0.0 < done < total:  # the time left at the rate so far
                took += f", about {remaining(spent * (total - done) / done)} left"
            self.log(f"{description}: {info(done)}{took}")

        def update(done: float) -> None:
            nonlocal t0, task
            first = t0 is None
            if first:
                t0 = time.monotonic()
            if self.live:
                if first:
                    task = self._progress.add_task(escape(description), total=total,
                                                   info=info(done))
                self._progress.update(task, completed=done, info=info(done))
                return
            if done >= total:
                self._running.pop(description, None)
            else:
                self._running[description] = lambda: line(done, False)
            if self._due(description, force=first or done >= total):
                line(done, first)
        return update

    def stage(self, stage: str, msg: str) -> None:
        """A stage of a longer job and what it is doing. In a log a new stage is always
        written; messages within a stage at most every ``interval`` s, and the stage's
        last message before the next stage starts."""
        new = stage != self._stage
        if new:
            self._stage, self._stage_t0 = stage, time.monotonic()
        if self.live:
            if self._stage_task is None:
                self._stage_task = self._progress.add_task(stage, total=None, info="")
            self._progress.update(self._stage_task, description=escape(stage),
                                  info=escape(msg))
            return
        if new and self._pending is not None:  # a stage's last word before the next one
            self.log(self._pending)
        took = time.monotonic() - self._stage_t0
        text = f"{stage}: {msg}" + ("" if new else f", {took:.0f} s")
        if self._due("stage", force=new):
            self.log(text)
            self._pending = None
        else:
            self._pending = text

    def done(self, msg: str) -> None:
        """The job finished: the stage line says so (in a log: "done: <msg>")."""
        self.stage("done", msg)
        if self.live and self._stage_task is not None:
            self._progress.update(self._stage_task, total=1, completed=1)
