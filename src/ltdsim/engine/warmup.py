"""Compile the kernels a piece of work needs before it starts, and say so while it happens.

On a new machine (or after ltdsim's compiled sources change) numba compiles the kernels
once and keeps them in its on-disk cache (see :mod:`ltdsim._jitcache`); later runs load
them in well under a second. :func:`warm_up` does that compile or load up front:

* the command line can show "compiling (first run only)" with the elapsed time instead
  of sitting silent;
* a sweep compiles once in the parent process, so its worker processes load the kernel
  from the cache instead of each compiling the same kernel at the same time.

A kernel is only as fast to load as its argument types allow: every distinct set of
argument types is a separate compile, so the kernels are called here exactly as
:func:`ltdsim.simulate` and the gear rig call them.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

#: ``tick(elapsed_s, done)``: called when a compile starts (0 s, False), every
#: ``interval`` seconds while it runs, and once when it ends (total s, True)
Tick = Callable[[float, bool], None]


@dataclass(frozen=True, eq=False)
class KernelCall:
    """A compiled function and the arguments of a call that does (almost) no work."""

    name: str
    dispatcher: object
    args: tuple
    #: how another process makes the same call: ``(function, arguments)``, the function
    #: at module level returning this call (:func:`warm_up` with ``parallel``)
    recipe: tuple | None = None
    #: calls of the kernel's own cached callees, compiled before it by :func:`warm_up`
    #: with ``parallel`` when this kernel is the only one to compile: the first (the
    #: right-hand side, the largest) in a worker process, the others here meanwhile
    parts: tuple = ()

    def signature(self) -> tuple:
        """numba's argument types of the call (what a compile is specialised on)."""
        return tuple(self.dispatcher.typeof_pyval(a) for a in self.args)

    def ready(self) -> bool | None:
        """True when the kernel for these argument types is in memory or in numba's
        on-disk cache (a load, not a compile), False when it must be compiled, None
        when numba's cache cannot be inspected."""
        sig = self.signature()
        disp = self.dispatcher
        if sig in disp.overloads:
            return True
        try:  # numba's own cache lookup (numba.core.caching.Cache._load_overload)
            from numba.core.caching import NullCache

            cache = disp._cache
            if isinstance(cache, NullCache):  # a function without cache=True
                return False
            key = cache._index_key(sig, disp.targetctx.codegen())
            return key in cache._cache_file._load_index()
        except Exception:  # noqa: BLE001 - a numba without these internals: unknown
            return None

    def __call__(self):
        return self.dispatcher(*self.args)


def scenario_kernels(scenarios: Iterable) -> list[KernelCall]:
    """The kernel calls that simulating each of ``scenarios`` needs, one per distinct
    kernel and argument types (a sweep of fixed-step cases needs one)."""
    from ltdsim.engine.lowering import lower
    from ltdsim.engine.run import zero_step_call

    calls, seen = [], set()
    for sc in scenarios:
        disp, args = zero_step_call(lower(sc))
        call = KernelCall("adaptive kernel (bs23)" if disp.__name__ == "run_adaptive"
                          else "fixed-step kernel", disp, args,
                          recipe=(_scenario_call, (sc,)), parts=_kernel_parts(sc, disp, args))
        key = (disp.__name__, call.signature())
        if key not in seen:
            seen.add(key)
            calls.append(call)
    return calls


def _scenario_call(sc) -> KernelCall:
    """The one kernel call of :func:`scenario_kernels` for scenario ``sc``."""
    return scenario_kernels([sc])[0]


def _scenario_part(sc, i: int) -> KernelCall:
    """Part ``i`` of the kernel call of :func:`scenario_kernels` for scenario ``sc``."""
    return scenario_kernels([sc])[0].parts[i]


def _kernel_parts(sc, disp, args) -> tuple:
    """Calls of the kernel ``disp``'s largest cached callees with the argument types the
    kernel gives them (from the kernel call's own ``args``, which they may scribble on:
    they advance nothing): the right-hand side (about 40 % of the study kernel's
    compile), then the brake commands, the controller, the record and the plausibility
    check (about 25 %). A part whose types differ from the kernel's is only a wasted
    compile: the kernel compiles what it needs itself."""
    from ltdsim.engine.kernel import driver, recording
    from ltdsim.engine.kernel import rhs as rhs_module

    y, ctl = args[0], args[1]
    tr, cp, dr, w, out = args[-5:]
    st = ctl.state[0]
    a_dem, n_ev, level = float(st["a_dem"]), int(st["n_events"]), float(st["level"])
    speed_mode = False  # (the record's type is a bool; its value does not matter here)
    rhs = rhs_module.rhs_split if disp.__name__ == "run_adaptive" else rhs_module.rhs
    ny = y.shape[0]
    spec = [("right-hand side", rhs, (0.0, y, a_dem, n_ev, tr, cp, dr, ctl.events, w,
                                      w.K[0:ny])),
            ("brake commands", driver._brake_commands, (0.0, 1e-3, y, ctl, tr, dr, w, False)),
            ("controller", driver._controller, (0.0, y, ctl, tr, dr, w)),
            ("record", recording._record, (0, 0.0, y, w.K, a_dem, level, speed_mode, tr,
                                           dr, w, out)),
            ("plausibility", recording._implausible, (y, tr, cp.par))]
    return tuple(KernelCall(name, f, a, recipe=(_scenario_part, (sc, i)))
                 for i, (name, f, a) in enumerate(spec))


def _compile(recipe: tuple) -> None:
    """Make the call of ``recipe`` (in a worker process of :func:`warm_up`): numba
    compiles its kernel into the on-disk cache."""
    make, args = recipe
    make(*args)()


def gear_rig_kernel() -> KernelCall:
    """The gear rig (:func:`ltdsim.analysis.gears.drive_deflection`, used by the model reduction);
    its argument types do not depend on the gear (the coupler model is a number)."""
    import numpy as np

    from ltdsim.engine.rig import RIG_DEFLECTION, _lowered_gear, _rig, rig_args
    from ltdsim.scenario import CouplerParams

    any_gear = CouplerParams(model="simplified", slack=0.0, damping=1.0, k1=1.0, k2=1.0,
                             k3=1.0, v_c=1.0)
    model, cpl, ctab = _lowered_gear(any_gear)
    t = np.array([0.0, 1e-4])
    return KernelCall("gear rig", _rig, rig_args(model, cpl, ctab, RIG_DEFLECTION, t, t * 0.0,
                                                 t * 0.0, 1.0, 0.0, 1e-4, "ode3"),
                      recipe=(gear_rig_kernel, ()))


def warm_up(calls: Iterable[KernelCall], tick: Tick | None = None,
            interval: float = 1.0, load: bool = True, parallel: bool = False) -> float:
    """Compile (or load from the cache) every kernel of ``calls``; returns the seconds
    spent compiling (0 when everything was in the cache).

    With ``load=False`` a kernel already in numba's on-disk cache is left there (for a
    process that only hands the work to others, such as a sweep's: its workers load
    the kernels themselves, and loading them here too only delays their start).

    ``tick(elapsed_s, done)`` reports a compile: once when it starts, every
    ``interval`` seconds while it runs (from a helper thread: the compile itself runs
    here, so Ctrl-C stops it) and once at the end. Loads from the cache take well under
    a second and are not reported.

    With ``parallel`` and more than one kernel to compile, each is compiled in a worker
    process of its own, side by side on the cores (numba compiles one kernel on one
    core), into the on-disk cache, and then loaded here; the workers end with this
    process (:func:`ltdsim._workers.process_executor`).
    """
    calls = list(calls)
    todo = [c for c in calls if c.ready() is not True]
    for c in calls if load else ():
        if c not in todo:
            c()  # load from the cache now, so the first case does not
    if not todo:
        return 0.0
    t0 = time.perf_counter()
    stop = threading.Event()

    def ticker():
        while not stop.wait(interval):
            tick(time.perf_counter() - t0, False)

    thread = None
    if tick is not None:
        tick(0.0, False)
        thread = threading.Thread(target=ticker, name="ltdsim-compile-ticker", daemon=True)
        thread.start()
    try:
        if parallel and len(todo) > 1 and all(c.recipe is not None for c in todo):
            _compile_side_by_side(todo)
        elif parallel and len(todo) == 1 and todo[0].parts:
            _compile_parts(todo[0].parts)
        for c in todo:
            c()  # (after the workers: a load from the cache)
    finally:
        stop.set()
        if thread is not None:
            thread.join()
    elapsed = time.perf_counter() - t0
    if tick is not None:
        tick(elapsed, True)
    return elapsed


def _compile_parts(parts) -> None:
    """Compile the first of ``parts`` (the right-hand side) in a worker process and the
    others here meanwhile, into numba's cache, so that the kernel's own compile then
    loads them: on two cores the first run's compile of the study's kernel takes the
    right-hand side's time less. Nothing when the machine has one core; a part that
    fails is left to the kernel's own compile."""
    import os

    from ltdsim._workers import process_executor

    if (os.cpu_count() or 1) < 2 or parts[0].ready() is True:
        return
    with process_executor(1) as pool:
        first = pool.submit(_compile, parts[0].recipe)
        for part in parts[1:]:
            try:
                part()
            except Exception:  # noqa: BLE001 - the kernel compiles it again, or says why
                pass
        try:
            first.result()
        except Exception:  # noqa: BLE001 - likewise
            pass


def _compile_side_by_side(todo: list[KernelCall]) -> None:
    """Compile every call of ``todo`` into numba's cache, each in a worker process."""
    import os

    from ltdsim._workers import process_executor

    workers = min(len(todo), os.cpu_count() or 1)
    with process_executor(workers) as pool:
        for f in [pool.submit(_compile, c.recipe) for c in todo]:
            f.result()
