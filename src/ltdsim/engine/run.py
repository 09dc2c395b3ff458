"""Run a lowered scenario through the compiled kernel: the records it fills, the memory
a run needs, the kernel called chunk by chunk with progress, and the error when the
state stops being finite. :func:`ltdsim.simulate` (``ltdsim.results.simulate``) turns
the records into the result."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ltdsim.engine import kernel
from ltdsim.engine.integrators import get_tableau
from ltdsim.engine.layout import (
    ABSURD_DEFLECTION, ABSURD_PRESSURE, ABSURD_SPEED, I_CELLS, I_PIPE, N_DRIVE_SIGNALS,
    N_ENERGY, N_EVENT_COLUMNS,
)
from ltdsim.engine.lowering import MAX_EVENTS, N_DRIVE_STATES, Lowered
from ltdsim.errors import ScenarioError, SimulationError
from ltdsim.physics.air.brakevalves import N_CV, N_DV
from ltdsim.scenario import Scenario
from ltdsim.variables import RECORD_ARRAYS

ProgressFn = Callable[[float, float], None]

def recorded(scenario: Scenario) -> frozenset[str]:
    """The kernel's record arrays (:data:`RECORD_ARRAYS` keys) a run of ``scenario``
    fills: all of them unless ``solver.record`` names a selection."""
    names = scenario.solver.record
    keys = (frozenset(RECORD_ARRAYS) if names is None else
            frozenset(k for k, vs in RECORD_ARRAYS.items() if set(vs) & set(names)))
    return keys if scenario.solver.energy else keys - {"e"}

#: share of the memory available when a run starts (``MemAvailable`` in /proc/meminfo)
#: that one run's recording may take; a longer recording is refused before anything is
#: allocated (see :func:`check_memory`)
MEMORY_SHARE = 0.5


def recording_bytes(scenario: Scenario) -> int:
    """Memory a run of ``scenario`` needs, bytes: the recording (``n_samples`` x the
    recorded values per sample x 8 bytes: position, velocity and acceleration per
    vehicle, deflection and force per coupler, 6 train signals, brake force and cylinder
    per braked vehicle, force per locomotive consist), the variables the result adds
    (relative position and velocity per vehicle, speed error, time; with ``[curving]``
    the coupler angles and lateral forces, L/V and wheelset forces), and the kernel's
    state and work arrays (an upper bound). Computed from the scenario alone, without
    allocating anything."""
    sv = scenario.solver
    n = scenario.n_vehicles
    nc = max(n - 1, 0)
    braked = sum(v.brake is not None for v in scenario.vehicles)
    nb = n if braked else 0
    nk = len(scenario.consists())
    n_samples = sv.n_steps // sv.record_every + 1
    nd = sum((loco.drive or scenario.traction.drive) == "induction"
             for loco in scenario.consists())
    keep = recorded(scenario)
    per_sample = (n * (("x" in keep) + ("v" in keep) + ("a" in keep))
                  + nc * (("d" in keep) + ("f" in keep)) + kernel.N_SCALARS
                  + nb * (("b" in keep) + ("p" in keep))
                  + (nk if nk > 1 and "c" in keep else 0)
                  + n * (("x" in keep) + ("v" in keep)) + 2
                  + (2 * nd * N_DRIVE_SIGNALS if "m" in keep else 0)
                  + (2 * (N_ENERGY + nc + 1) if "e" in keep else 0)
                  # [curving]'s series the result adds (ltdsim.results.safety.add_curving):
                  # angle and lateral force per coupler, L/V and wheelset force per vehicle
                  + (2 * nc + 2 * n if scenario.curving is not None else 0))
    ny = 2 * n + nc + nb  # positions, speeds, a force state per coupler, brake fills
    if sv.energy and sv.adaptive:  # (bs23 integrates the energy terms as states)
        ny += N_ENERGY + nc
    cells = 0
    if scenario.brake.model == "fluid":
        # pipe, auxiliary reservoir and cylinder pressure per vehicle, exhausted air;
        # the pipe's cells and faces, every valve's states, the pipe's work array
        per_sample += n * (("bp" in keep) + ("ar" in keep) + ("bc" in keep)) + ("ax" in keep)
        cells = n * scenario.brake.fluid.cells_per_vehicle
        ny += 3 * cells + braked * N_CV + nk * N_DV + 1
    stages = 4 if sv.adaptive else get_tableau(sv.method).stages
    air_steps = sv.adaptive and scenario.brake.model == "fluid"
    ny += nd * N_DRIVE_STATES
    work = (kernel.work_size(n, ny, stages, nk, cells, air_steps, nd, sv.energy)
            + 4 * ny + 4 * nc + n + 2 + nk
            + (n + 1 if scenario.curving is not None else 0))  # (curving's limits)
    return 8 * (n_samples * per_sample + work)


def available_memory() -> int | None:
    """Memory available for new work now, bytes (``MemAvailable`` of /proc/meminfo on
    Linux, else free physical pages), or None where neither can be read."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def _gb(nbytes: float) -> str:
    """A size in GB (10^9 bytes), e.g. ``0.0328 GB``, ``12.5 GB``, ``32,801 GB``."""
    gb = nbytes / 1e9
    return f"{gb:,.0f} GB" if gb >= 100 else f"{gb:.3g} GB"


def check_memory(scenario: Scenario, source: str | None = None, parallel: int = 1,
                 largest: int | None = None) -> int:
    """Refuse, before anything is allocated, a run whose recording would take more than
    :data:`MEMORY_SHARE` of the memory available; returns the estimate, bytes.

    ``parallel`` runs of up to ``largest`` bytes each (default: the estimate of
    ``scenario``, :func:`recording_bytes`) at once, as in a sweep. Raises
    :class:`~ltdsim.errors.ScenarioError` naming the estimate in GB and the keys to
    change (``solver.output_interval``, ``solver.t_end``).
    """
    need = recording_bytes(scenario) if largest is None else largest
    avail = available_memory()
    if avail is None or need * parallel <= MEMORY_SHARE * avail:
        return need
    sv = scenario.solver
    n_samples = sv.n_steps // sv.record_every + 1
    runs = (f"; {parallel} runs at once need {_gb(need * parallel)} (fewer with "
            "--workers)" if parallel > 1 else "")
    raise ScenarioError(source or f"scenario {scenario.name!r}", [(
        "solver.output_interval, solver.t_end",
        f"the recording would need about {_gb(need)} ({n_samples:,} samples of "
        f"{scenario.n_vehicles} vehicles at output_interval = {sv.output_interval:g} s up "
        f"to t_end = {sv.t_end:g} s){runs}: more than {MEMORY_SHARE:.0%} of the "
        f"{_gb(avail)} of memory available; raise solver.output_interval, lower "
        "solver.t_end or record fewer time series (solver.record)")])



#: The cost model of :func:`estimate`, seconds of wall time on one core, measured on the
#: project's 2-core reference machine with the shipped scenarios (docs/solver.md
#: "Estimates"): a fixed-step stage per vehicle; a bs23 stage per vehicle (its error
#: norm and step control included); an induction drive per stage; one fluid-brake
#: pipe cell per pneumatic step (its valves included)
SECONDS_PER_FIXED_STAGE_VEHICLE = 1.4e-8
SECONDS_PER_ADAPTIVE_STAGE_VEHICLE = 2.5e-8
SECONDS_PER_DRIVE_STAGE = 1.3e-7
SECONDS_PER_AIR_CELL_STEP = 2.5e-7
#: a run estimated to take longer than this (s) is refused unless the caller raises
#: the limit (``--max-time`` of the commands; ``time_limit`` of ``ltdsim.simulate``)
TIME_LIMIT = 3600.0
#: a run estimated to take longer than this (s) has its estimate printed before it starts
ANNOUNCE_TIME = 60.0


@dataclass(frozen=True)
class Estimate:
    """What a run will take, before it starts (:func:`estimate`)."""

    steps: float  #: steps of the train's states, - (bs23: an estimate)
    air_steps: float  #: bs23 with the fluid brake: steps of the pneumatic states, -
    seconds: float  #: wall time on one core of the reference machine, s
    bytes: int  #: memory, bytes (:func:`recording_bytes`)
    what: str  #: what sets the step, in words
    exact: bool  #: the step count is exact (fixed step), not estimated (bs23)

    @property
    def keys(self) -> str:
        """The keys that shorten a run, as a message names them."""
        return ("solver.dt, solver.t_end" if self.exact else
                "solver.rtol, solver.atol, solver.max_step, solver.t_end")

    def line(self, wall: bool = True) -> str:
        """The estimate in words, e.g. ``2,700,000 steps (step set by solver.dt = 0.0001
        s (ode3)), about 1 min 30 s and 0.0328 GB of memory`` (without the time when not
        ``wall``)."""
        steps = f"{self.steps:,.0f} steps" if self.exact else f"about {self.steps:,.0f} steps"
        air = (f" and about {self.air_steps:,.0f} pneumatic steps" if self.air_steps else "")
        took = f"about {duration(self.seconds)} and " if wall else ""
        return f"{steps}{air} (step set by {self.what}), {took}{_gb(self.bytes)} of memory"


def duration(seconds: float) -> str:
    """A wall time in words: ``0.4 s``, ``45 s``, ``12 min 05 s``, ``3 h 20 min``,
    ``1.2e+04 days``."""
    if not math.isfinite(seconds):
        return "forever"
    if seconds < 10.0:
        return f"{seconds:.2g} s"
    if seconds < 60.0:
        return f"{seconds:.0f} s"
    if seconds < 3600.0:
        m, sec = divmod(round(seconds), 60)
        return f"{m} min {sec:02d} s"
    if seconds < 86400.0 * 3:
        h, m = divmod(round(seconds / 60.0), 60)
        return f"{h} h {m:02d} min"
    return f"{seconds / 86400.0:.3g} days"


def estimate(scenario: Scenario) -> Estimate:
    """Steps, wall time and memory a run of ``scenario`` will take, from the scenario
    alone (nothing is allocated or compiled): the steps of
    :func:`ltdsim.engine.preflight.expected_steps` (exact for a fixed step; for bs23 from
    the stiffest rate), each costed by the model above (vehicles, induction drives and
    pipe cells per stage), and :func:`recording_bytes`. Good to a factor of about 2 on
    the reference machine; the progress line corrects it as the run goes."""
    from ltdsim.engine.preflight import expected_steps

    sv = scenario.solver
    count = expected_steps(scenario)
    n = scenario.n_vehicles
    nd = sum((loco.drive or scenario.traction.drive) == "induction"
             for loco in scenario.consists())
    fluid = scenario.brake.model == "fluid" and any(v.brake is not None
                                                    for v in scenario.vehicles)
    cells = n * scenario.brake.fluid.cells_per_vehicle if fluid else 0
    if sv.adaptive:
        per_step = 4 * (n * SECONDS_PER_ADAPTIVE_STAGE_VEHICLE + nd * SECONDS_PER_DRIVE_STAGE)
        air = count.air_steps * cells * SECONDS_PER_AIR_CELL_STEP
    else:
        stages = get_tableau(sv.method).stages
        per_step = (stages * (n * SECONDS_PER_FIXED_STAGE_VEHICLE
                              + nd * SECONDS_PER_DRIVE_STAGE)
                    + cells * SECONDS_PER_AIR_CELL_STEP)
        air = 0.0
    return Estimate(count.steps, count.air_steps, count.steps * per_step + air,
                    recording_bytes(scenario), count.what
                    + (f"; pneumatic steps by {count.air_what}" if count.air_steps else ""),
                    not sv.adaptive)


#: how a library caller runs a long run anyway (the commands name their own option)
LIBRARY_ANYWAY = "pass time_limit = None (or more seconds) to ltdsim.simulate"


def check_time(scenario: Scenario, limit: float | None = TIME_LIMIT,
               source: str | None = None, anyway: str = LIBRARY_ANYWAY) -> Estimate:
    """Refuse, before anything is compiled or allocated, a run estimated
    (:func:`estimate`) to take longer than ``limit`` seconds (None: no limit); returns
    the estimate. Raises :class:`~ltdsim.errors.ScenarioError` naming the estimate, what
    sets the step, the keys to change and, in ``anyway``, how to raise the limit."""
    est = estimate(scenario)
    if limit is None or est.seconds <= limit:
        return est
    raise ScenarioError(source or f"scenario {scenario.name!r}", [(
        est.keys, f"the run would take about {duration(est.seconds)} ({est.line(False)}), beyond "
              f"the limit of {duration(limit)}; raise the step, shorten solver.t_end, or "
              f"{anyway} to run it anyway")])


def _buffers(low: Lowered, n_rec: int, keep: frozenset[str] = frozenset(RECORD_ARRAYS)):
    """Records, state, controller, bs23 step state, step grid and the kernels' common
    argument tail (train, couplers, driver, work, outputs) for a run of ``low`` with
    ``n_rec`` records of the record arrays ``keep`` (the others get width 0: the kernel
    skips them)."""
    n = low.n
    nc = max(n - 1, 0)
    nk = low.cons.shape[0]
    nb = n if low.braked else 0
    nf = n if low.fluid else 0

    def cols(key: str, width: int) -> int:
        return width if key in keep else 0

    rec = {
        "x": np.empty((n_rec, cols("x", n))), "v": np.empty((n_rec, cols("v", n))),
        "a": np.empty((n_rec, cols("a", n))),
        "d": np.empty((n_rec, cols("d", nc))), "f": np.empty((n_rec, cols("f", nc))),
        "s": np.empty((n_rec, kernel.N_SCALARS)),
        "b": np.zeros((n_rec, cols("b", nb))), "p": np.zeros((n_rec, cols("p", nb))),
        "c": np.zeros((n_rec, cols("c", nk if nk > 1 else 0))),
        "bp": np.zeros((n_rec, cols("bp", nf))), "ar": np.zeros((n_rec, cols("ar", nf))),
        "bc": np.zeros((n_rec, cols("bc", nf))),
        "ax": np.zeros((n_rec, cols("ax", 1 if nf else 0))),
        "m": np.zeros((n_rec, cols("m", low.drive_z.size), N_DRIVE_SIGNALS)),
        "e": np.zeros((n_rec, cols("e", N_ENERGY + nc + 1) if low.energy else 0)),
        "peaks": np.tile([-np.inf, np.inf, 0.0, 0.0], (nc, 1)),
        "events": np.zeros((MAX_EVENTS, N_EVENT_COLUMNS)),
    }
    y = low.y0.copy()
    ctl = kernel.make_controller(rec["events"])
    tab = low.tableau
    stages = tab.stages + 1 if low.adaptive else tab.stages  # (bs23: + the step's end)
    out = kernel.Outputs(**{k: rec[k] for k in kernel.Outputs._fields})
    common = (kernel.make_train(low), kernel.make_couplers(low), kernel.make_driver(low),
              kernel.make_work(n, y.shape[0], stages, nk, low.pipe_dx_cell.size,
                               air_steps=low.adaptive and low.fluid,
                               drives=low.drive_z.size, energy=low.energy,
                               braked=low.braked, hold=low.hold_speed > 0.0), out)
    if low.adaptive:
        err_atol = low.atol.copy()
        err_atol[low.gear_f1] = np.inf
        err_atol[low.gear_plate[low.gear_plate >= 0]] = np.inf
        grid = kernel.Adaptive(out_dt=low.record_every * low.dt, n_rec=n_rec,
                               hold_speed=low.hold_speed, hold_ftol=low.hold_ftol,
                               h_max=low.max_step,
                               air_h_max=low.air_max_step, atol=low.atol, rtol=low.rtol, A=tab.A,
                               b=tab.b, c=tab.c, e=tab.e, err_atol=err_atol,
                               gear_f1=low.gear_f1, gear_of=low.gear_of,
                               gear_plate=low.gear_plate, gear_exact=low.gear_exact)
    else:
        grid = kernel.FixedStep(dt=low.dt, n_steps=low.n_steps, record_every=low.record_every,
                                energy_every=low.energy_every, A=tab.A, b=tab.b, c=tab.c)
    if low.hold_speed > 0.0:  # (the couplings that may be held at their slack edge)
        common[3].hold_f[:] = low.hold_f
    stepper = kernel.make_stepper(low.dt)  # bs23 carry-over
    return rec, y, ctl, stepper, grid, common


def zero_step_call(low: Lowered):
    """``(kernel, args)``: the compiled kernel that runs ``low`` (fixed-step
    :func:`ltdsim.engine.kernel.run` or adaptive :func:`ltdsim.engine.kernel.run_adaptive`) and the
    arguments of a call that advances nothing. Calling it compiles the kernel for these
    argument types, or loads it from numba's cache."""
    _, y, ctl, stepper, grid, common = _buffers(low, 1)
    if low.adaptive:
        return kernel.run_adaptive, (y, ctl, stepper, 0, 0, grid, *common)
    return kernel.run, (y, ctl, 0, 0, grid, *common)


#: wall time one kernel call of :func:`integrate` aims at, s (progress and Ctrl-C are
#: seen between calls)
CHUNK_SECONDS = 1.0
#: the first kernel call covers at most this share of the records, 1 / FIRST_CHUNKS
FIRST_CHUNKS = 1000


def integrate(low: Lowered, scenario: Scenario, progress, chunks):
    """Run the kernel over the whole scenario."""
    n_rec_total = low.n_steps // low.record_every + 1
    try:
        rec, y, ctl, stepper, grid, common = _buffers(low, n_rec_total, recorded(scenario))
    except MemoryError:  # the memory went to other work since check_memory looked
        raise SimulationError(
            f"not enough memory for the recording ({n_rec_total:,} samples, about "
            f"{_gb(recording_bytes(scenario))}); raise solver.output_interval or lower "
            "solver.t_end", time=0.0) from None
    out_dt = low.record_every * low.dt
    t_end = low.n_steps * low.dt
    per_rec = max(1, (n_rec_total - 1) // max(chunks, 1))
    # a call's records: at most per_rec; after each call scaled so that a call lasts
    # about CHUNK_SECONDS (the first call is short: a run of unknown cost reports early)
    size = max(1, min(per_rec, (n_rec_total - 1) // FIRST_CHUNKS))
    r = 0
    k = 0
    while True:
        t_call = time.perf_counter()
        if low.adaptive:
            r_stop = min(r + size, n_rec_total)
            status, t_at = kernel.run_adaptive(y, ctl, stepper, r, r_stop, grid, *common)
            r = r_stop
            done = r >= n_rec_total
            t_done = min(r, n_rec_total - 1) * out_dt
        else:
            k_stop = min(k + size * low.record_every, low.n_steps)
            status, k_end = kernel.run(y, ctl, k, k_stop, grid, *common)
            t_at = k_end * low.dt
            k = k_stop
            done = k >= low.n_steps
            t_done = k * low.dt
        spent = time.perf_counter() - t_call
        grow = CHUNK_SECONDS / spent if spent > 0.0 else 4.0
        size = max(1, min(per_rec, int(size * min(max(grow, 0.25), 4.0))))
        if status == kernel.EVENTS_FULL:
            raise SimulationError(
                f"more than {MAX_EVENTS} brake commands by t = {t_at:.6g} s; raise "
                "brake.level_step or give fewer commands", time=t_at)
        if status == kernel.ABSURD:
            raise _absurd_error(scenario, low, y, t_at)
        if status != kernel.OK:
            raise _nonfinite_error(scenario, low, y, t_at)
        if progress is not None:
            progress(t_done, t_end)
        if done:
            break
    rec["n_events"] = int(ctl.state[0]["n_events"])
    st = stepper[0]
    rec["steps"] = (int(st["accepted"]), int(st["rejected"])) if low.adaptive else (low.n_steps, 0)
    rec["holds"] = int(st["holds"]) if low.adaptive else 0
    air = common[3].air_step[0]
    rec["air_steps"] = (int(air["accepted"]), int(air["rejected"]))
    return rec


def _nonfinite_error(scenario: Scenario, low: Lowered, y: np.ndarray, t: float) -> SimulationError:
    n = low.n
    x, v = y[:n], y[n:2 * n]
    bad = np.flatnonzero(~(np.isfinite(x) & np.isfinite(v)))
    i = int(bad[0]) if bad.size else None
    if low.adaptive:
        parts = [f"bs23 found no finite step beyond t = {t:.6g} s (step size fell below "
                 "1e-12 s)"]
    else:
        # (the kernel checks the state at record steps: it was finite at the one before)
        k = round(t / low.dt)
        k0 = max(((k - 1) // low.record_every) * low.record_every, 0)
        parts = [f"simulation state became non-finite between t = {k0 * low.dt:.6g} s and "
                 f"t = {t:.6g} s (steps {k0} to {k}; the state is checked at every record)"]
    j = None
    if n > 1:
        d = x[:-1] - x[1:] + low.d0
        badc = np.flatnonzero(~np.isfinite(d))
        if badc.size:
            j = int(badc[0])
    drive = None if low.adaptive else _fast_drive(scenario, low)
    if drive is not None:
        # an induction drive faster than the step: the couplers and vehicles only
        # follow it into NaN, so it is named instead of them
        parts += drive
        return SimulationError("; ".join(parts), time=t, vehicle=i, coupler=j)
    if i is not None:
        parts.append(f"vehicle {i + 1} ({scenario.vehicles[i].name!r}; 1 = lead): "
                     f"displacement = {x[i]:.6g} m, velocity = {v[i]:.6g} m/s")
    if j is not None:
        parts.append(f"coupler {j + 1} (between vehicles {j + 1} and {j + 2}): "
                     f"deflection = {d[j]:.6g} m")
    parts.append("hint: reduce solver.dt (or bs23 tolerances), or check stiffness and damping "
                 "against the masses")
    return SimulationError("; ".join(parts), time=t, vehicle=i, coupler=j)


def _absurd_error(scenario: Scenario, low: Lowered, y: np.ndarray, t: float) -> SimulationError:
    """The run stopped at time ``t`` (s) with the finite state ``y`` beyond a physical
    bound (:data:`ltdsim.engine.layout.ABSURD_SPEED`, ``ABSURD_DEFLECTION``,
    ``ABSURD_PRESSURE``): what is beyond which bound, the first few of each, and what to
    change."""
    n = low.n
    v = y[n:2 * n]
    d = y[:n - 1] - y[1:n] + low.d0 if n > 1 else np.zeros(0)
    parts = [f"the run blew up by t = {t:.6g} s: its state stayed finite but went beyond "
             "any physical bound (checked at every record)"]
    fast = np.flatnonzero(np.abs(v) > ABSURD_SPEED)
    if fast.size:
        parts.append(", ".join(f"vehicle {i + 1} ({scenario.vehicles[i].name!r}) at "
                               f"{v[i]:.3g} m/s" for i in fast[:3])
                     + (f" and {fast.size - 3} more" if fast.size > 3 else "")
                     + f" (1 = lead; beyond {ABSURD_SPEED:g} m/s)")
    far = np.flatnonzero(np.abs(d) > ABSURD_DEFLECTION)
    if far.size:
        parts.append(", ".join(f"coupler {j + 1} deflected {d[j]:.3g} m" for j in far[:3])
                     + (f" and {far.size - 3} more" if far.size > 3 else "")
                     + f" (beyond {ABSURD_DEFLECTION:g} m)")
    zp = int(low.air_index[I_PIPE])
    if zp >= 0:
        p = y[zp:zp + int(low.air_index[I_CELLS])]
        bad = np.flatnonzero((p < 0.0) | (p > ABSURD_PRESSURE))
        if bad.size:
            c = int(bad[0])
            parts.append(f"brake pipe cell {c + 1} of {p.size} (1 = lead end) at "
                         f"{p[c]:.3g} Pa absolute (bounds 0 to {ABSURD_PRESSURE:g} Pa)")
    i = int(fast[0]) if fast.size else None
    j = int(far[0]) if far.size else None
    hint = ("hint: reduce solver.dt or use the adaptive bs23" if not low.adaptive else
            "hint: tighten solver.rtol and solver.atol")
    if not scenario.solver.stability_check:
        hint += ", and turn solver.stability_check back on (it is off: it refuses a fixed " \
                "step its method cannot keep stable)"
    parts.append(hint + "; check stiffness and damping against the masses")
    return SimulationError("; ".join(parts), time=t, vehicle=i, coupler=j)


def _fast_drive(scenario: Scenario, low: Lowered) -> list[str] | None:
    """For a fixed step above what the method keeps stable on the fastest lag of an
    induction drive (its current loops, ``1 / (2 pi current_bandwidth)``, or its
    stator's transient ``sigma L_s / R_sigma``, the plant pole the loops' PI cancels,
    which stays a mode of the state): the message's parts naming the drive (consist,
    vehicles, motor keys), that time constant against ``solver.dt`` and the remedy;
    None otherwise."""
    from ltdsim.engine.preflight import real_radius
    from ltdsim.physics.drive import foc

    method, dt = scenario.solver.method, low.dt
    radius = real_radius(method)
    worst = None
    for k, j in enumerate(low.drive_of):
        if j < 0:
            continue
        loops, stator = foc.time_constants(low.drive_ctrl[j])
        lags = [(loops, "its current loops' time constant 1 / (2 pi "
                 "traction.motor.current_bandwidth)"),
                (stator, "its stator's transient "
                 "time constant sigma L_s / R_sigma (traction.motor's leakage "
                 "inductances and resistances)")]
        tau, what = min(lags)
        if dt > radius * tau and (worst is None or tau < worst[0]):
            worst = (tau, what, k)
    if worst is None:
        return None
    tau, what, k = worst
    loco = scenario.consists()[k]
    names = ", ".join(f"{i + 1} {scenario.vehicles[i].name!r}" for i in loco.vehicles[:3])
    more = f" and {len(loco.vehicles) - 3} more" if len(loco.vehicles) > 3 else ""
    motor = scenario.traction.motor
    return [f"the induction drive of consist {k + 1} ({loco.name!r}, vehicle"
            f"{'s' if len(loco.vehicles) > 1 else ''} {names}{more}; 1 = lead; motor "
            f"traction.motor, preset {motor.preset!r}) is faster than the step: {what} = "
            f"{tau:.3g} s against solver.dt = {dt:g} s, while {method} follows a lag "
            f"only down to solver.dt / {radius:.3g} = {dt / radius:.3g} s",
            f"hint: set solver.dt to at most {radius * tau:.3g} s, slow the drive "
            "(traction.motor.current_bandwidth), or use the adaptive bs23"]
