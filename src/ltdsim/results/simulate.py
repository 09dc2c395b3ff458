"""Run a scenario through the compiled kernel and return a labelled ``xarray.Dataset``."""

from __future__ import annotations

import json
import os
import time as _time
from collections.abc import Callable

import numpy as np
import xarray as xr

from ltdsim.engine import kernel
from ltdsim.errors import ScenarioError, SimulationError
from ltdsim.engine.layout import (DRIVE_SIGNALS, E_MOTOR, ENERGY_TERMS, N_DRIVE_SIGNALS,
                           N_ENERGY, N_EVENT_COLUMNS)
from ltdsim.engine.lowering import MAX_EVENTS, N_DRIVE_STATES, Lowered, lower
from ltdsim.engine.integrators import get_tableau
from ltdsim.scenario.model import ENERGY_VARIABLES, Scenario

#: Units of every variable in the result dataset.
UNITS = {
    "time": "s",
    "position": "m",
    "velocity": "m/s",
    "acceleration": "m/s^2",
    "relative_position": "m",
    "relative_velocity": "m/s",
    "coupler_deflection": "m",
    "coupler_force": "N",
    "traction_force": "N",
    "speed_reference": "m/s",
    "speed_error": "m/s",
    "adhesion_limit": "N",
    "demanded_acceleration": "m/s^2",
    "traction_demand": "N",
    "max_coupler_force": "N",
    "min_coupler_force": "N",
    "time_max_coupler_force": "s",
    "time_min_coupler_force": "s",
    "brake_command": "1",
    "brake_force": "N",
    "brake_cylinder": "1",
    "locomotive_force": "N",
    "brake_pipe_pressure": "Pa (gauge)",
    "auxiliary_reservoir_pressure": "Pa (gauge)",
    "brake_cylinder_pressure": "Pa (gauge)",
    "air_exhausted": "kg",
    "motor_torque": "N m",
    "motor_speed": "rad/s",
    "stator_current": "A (rms)",
    "creep": "1",
    "creep_force": "N",
    "dc_power": "W",
    "stator_flux_d": "Wb",
    "stator_flux_q": "Wb",
    "rotor_flux_d": "Wb",
    "rotor_flux_q": "Wb",
    **{name: "J" for name in ENERGY_VARIABLES},
}

DESCRIPTIONS = {
    "motor_torque": "induction drive: electromagnetic torque of one traction motor at its "
                    "shaft (NaN: a consist on the traction curve)",
    "motor_speed": "induction drive: shaft speed of one traction motor (x 30/pi for rpm)",
    "stator_current": "induction drive: stator winding current of one traction motor, rms",
    "creep": "induction drive: creep of the driven wheelsets, slip velocity over "
             "max(speed, v_reg)",
    "creep_force": "induction drive: longitudinal creep force of all the locomotive's "
                   "driven wheelsets, + forward",
    "dc_power": "induction drive: DC-link power of all the locomotive's inverters, + drawn "
                "(motoring), - returned (braking)",
    "stator_flux_d": "induction drive: stator flux linkage of one traction motor, d axis "
                     "of the controller's synchronous frame, peak",
    "stator_flux_q": "induction drive: stator flux linkage of one traction motor, q axis "
                     "of the controller's synchronous frame, peak",
    "rotor_flux_d": "induction drive: rotor flux linkage of one traction motor (referred "
                    "to the stator), d axis of the controller's synchronous frame, peak",
    "rotor_flux_q": "induction drive: rotor flux linkage of one traction motor (referred "
                    "to the stator), q axis of the controller's synchronous frame, peak",
    "position": "track position of the vehicle centre (lead vehicle starts at 0)",
    "velocity": "vehicle speed, + forwards",
    "acceleration": "vehicle acceleration",
    "relative_position": "position relative to the lead vehicle's, minus the initial offset "
                         "(x_i - x_0)",
    "relative_velocity": "velocity relative to the lead vehicle (v_i - v_0)",
    "coupler_deflection": "coupler deflection from neutral, + draft (stretched)",
    "coupler_force": "coupler force, + tension (draft), - compression (buff)",
    "traction_force": "total traction (+) or dynamic-brake (-) force of the powered vehicles",
    "speed_reference": "reference speed of the speed controller",
    "speed_error": "reference minus measured speed of the lead powered vehicle",
    "adhesion_limit": "Curtius-Kniffler adhesion limit at the lead powered vehicle's speed",
    "demanded_acceleration": "speed controller output after the acceleration limits",
    "traction_demand": "force demanded of the powered vehicles before the traction curve "
                       "(adhesion, force, power) limits it",
    "max_coupler_force": "largest coupler force over every step of the run (+ tension)",
    "min_coupler_force": "smallest coupler force over every step of the run (- compression)",
    "time_max_coupler_force": "time of max_coupler_force",
    "time_min_coupler_force": "time of min_coupler_force",
    "brake_command": "brake level last commanded at the brake-control points (0-1)",
    "brake_force": "air-brake retarding force, + opposing forward motion",
    "brake_cylinder": "brake-cylinder fill: 0 released, 1 full application (fluid brake: "
                      "cylinder pressure over a full service's)",
    "locomotive_force": "traction (+) or dynamic-brake (-) force of each locomotive consist",
    "brake_pipe_pressure": "brake-pipe pressure at the vehicle (the cell its valve "
                           "connects to), gauge",
    "auxiliary_reservoir_pressure": "auxiliary-reservoir pressure of the vehicle's control "
                                    "valve, gauge (NaN: unbraked vehicle)",
    "brake_cylinder_pressure": "brake-cylinder pressure, gauge (NaN: unbraked vehicle)",
    "air_exhausted": "air the brake has let out to atmosphere since the start (vents, "
                     "exhausts, leaks; less what compressors took in)",
    "traction_energy": "work of the traction force at the rail while motoring (its power "
                       "on each vehicle > 0), since the start",
    "dynamic_brake_energy": "work the dynamic brake took from the train at the rail, since "
                            "the start (>= 0; the most it can regenerate)",
    "air_brake_energy": "work of the air brakes (shoe friction), since the start",
    "davis_energy": "work against the Davis running resistance, since the start",
    "grade_energy": "work against gravity on grades since the start: the potential energy "
                    "gained (< 0 downhill)",
    "curve_energy": "work against curve resistance, since the start",
    "coupler_energy": "net work the coupler took since the start: what its gears "
                      "dissipated plus what they store at that moment",
    "kinetic_energy": "kinetic energy of the train, sum of m v^2 / 2 with the dynamic "
                      "masses (rotating parts included)",
    "energy_balance_error": "traction_energy - dynamic_brake_energy - air_brake_energy - "
                            "davis_energy - grade_energy - curve_energy - the couplers' "
                            "energy - the change of kinetic_energy: what the integration "
                            "leaves unaccounted",
}

ProgressFn = Callable[[float, float], None]

#: the kernel's record arrays and the result variables each one gives; ``solver.record``
#: names variables, and an array is recorded when one of its variables is named
#: (``relative_position`` comes with ``position``; ``relative_velocity`` and
#: ``speed_error`` with ``velocity``; the drive's signals are recorded together)
RECORD_ARRAYS = {
    "x": ("position",), "v": ("velocity",), "a": ("acceleration",),
    "d": ("coupler_deflection",), "f": ("coupler_force",),
    "b": ("brake_force",), "p": ("brake_cylinder",), "c": ("locomotive_force",),
    "bp": ("brake_pipe_pressure",), "ar": ("auxiliary_reservoir_pressure",),
    "bc": ("brake_cylinder_pressure",), "ax": ("air_exhausted",),
    "m": DRIVE_SIGNALS,
    "e": ENERGY_VARIABLES,
}


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
    (relative position and velocity per vehicle, speed error, time), and the kernel's
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
                  + (2 * (N_ENERGY + nc + 1) if "e" in keep else 0))
    ny = 2 * n + nc + nb  # positions, speeds, a force state per coupler, brake fills
    if sv.energy and sv.adaptive:  # (bs23 integrates the energy terms as states)
        ny += N_ENERGY + nc
    cells = 0
    if scenario.brake.model == "fluid":
        # pipe, auxiliary reservoir and cylinder pressure per vehicle, exhausted air;
        # the pipe's cells and faces, every valve's states, the pipe's work array
        per_sample += n * (("bp" in keep) + ("ar" in keep) + ("bc" in keep)) + ("ax" in keep)
        cells = n * scenario.brake.fluid.cells_per_vehicle
        ny += 2 * cells + braked * kernel.N_CV + nk * kernel.N_DV + 1
    stages = 4 if sv.adaptive else get_tableau(sv.method).stages
    air_steps = sv.adaptive and scenario.brake.model == "fluid"
    ny += nd * N_DRIVE_STATES
    work = (kernel.work_size(n, ny, stages, nk, cells, air_steps, nd, sv.energy)
            + 4 * ny + 4 * nc + n + 2 + nk)
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



def simulate(scenario: Scenario, progress: ProgressFn | None = None,
             chunks: int = 100) -> xr.Dataset:
    """Simulate ``scenario`` and return its time series.

    Parameters
    ----------
    scenario : Scenario
        A validated scenario (see :func:`ltdsim.load_scenario`).
    progress : callable, optional
        Called as ``progress(t_done, t_end)`` in seconds of simulated time after each
        chunk of steps.
    chunks : int
        Number of kernel calls the run is split into (for progress and Ctrl-C).

    Returns
    -------
    xarray.Dataset
        ``position``, ``velocity``, ``acceleration``, ``relative_position``,
        ``relative_velocity`` (time x vehicle); ``coupler_deflection``,
        ``coupler_force`` (time x coupler); ``traction_force``, ``speed_reference``,
        ``speed_error``, ``adhesion_limit``, ``demanded_acceleration``,
        ``traction_demand`` (time); with the induction drive ``motor_torque``,
        ``motor_speed``, ``stator_current``, ``creep``, ``creep_force``, ``dc_power``,
        ``stator_flux_d``, ``stator_flux_q``, ``rotor_flux_d``, ``rotor_flux_q``
        (time x locomotive, NaN for a consist on the traction curve); of the time
        series only those ``solver.record`` names, when it names a selection. Units are
        in each variable's ``units`` attribute; the scenario (JSON) and run facts are in
        the dataset's attributes.

    Raises
    ------
    ScenarioError
        Before anything is allocated, if the recording would take more than
        :data:`MEMORY_SHARE` of the memory available (:func:`check_memory`).
    SimulationError
        If the state becomes non-finite; the message names the time, the vehicle and
        coupler, and their values.
    """
    check_memory(scenario)
    low = lower(scenario)
    t0 = _time.perf_counter()
    kern, args = zero_step_call(low)
    kern(*args)  # compile, or load from numba's cache (see ltdsim.engine.warmup)
    t1 = _time.perf_counter()
    rec = _integrate(low, scenario, progress, chunks)
    wall = _time.perf_counter() - t1
    return _dataset(scenario, low, rec, wall, compile_time=t1 - t0)


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
                               braked=low.braked), out)
    if low.adaptive:
        err_atol = low.atol.copy()
        err_atol[low.gear_f1] = np.inf
        err_atol[low.gear_plate[low.gear_plate >= 0]] = np.inf
        grid = kernel.Adaptive(out_dt=low.record_every * low.dt, n_rec=n_rec,
                               h_max=low.max_step,
                               air_h_max=low.air_max_step, atol=low.atol, rtol=low.rtol, A=tab.A,
                               b=tab.b, c=tab.c, e=tab.e, err_atol=err_atol,
                               gear_f1=low.gear_f1, gear_of=low.gear_of,
                               gear_plate=low.gear_plate, gear_exact=low.gear_exact)
    else:
        grid = kernel.FixedStep(dt=low.dt, n_steps=low.n_steps, record_every=low.record_every,
                                A=tab.A, b=tab.b, c=tab.c)
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


def _integrate(low: Lowered, scenario: Scenario, progress, chunks):
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
    r = 0
    k = 0
    while True:
        if low.adaptive:
            r_stop = min(r + per_rec, n_rec_total)
            status, t_at = kernel.run_adaptive(y, ctl, stepper, r, r_stop, grid, *common)
            r = r_stop
            done = r >= n_rec_total
            t_done = min(r, n_rec_total - 1) * out_dt
        else:
            k_stop = min(k + per_rec * low.record_every, low.n_steps)
            status, k_end = kernel.run(y, ctl, k, k_stop, grid, *common)
            t_at = k_end * low.dt
            k = k_stop
            done = k >= low.n_steps
            t_done = k * low.dt
        if status == kernel.EVENTS_FULL:
            raise SimulationError(
                f"more than {MAX_EVENTS} brake commands by t = {t_at:.6g} s; raise "
                "brake.level_step or give fewer commands", time=t_at)
        if status != kernel.OK:
            raise _nonfinite_error(scenario, low, y, t_at)
        if progress is not None:
            progress(t_done, t_end)
        if done:
            break
    rec["n_events"] = int(ctl.state[0]["n_events"])
    st = stepper[0]
    rec["steps"] = (int(st["accepted"]), int(st["rejected"])) if low.adaptive else (low.n_steps, 0)
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
    if i is not None:
        parts.append(f"vehicle {i + 1} ({scenario.vehicles[i].name!r}; 1 = lead): "
                     f"displacement = {x[i]:.6g} m, velocity = {v[i]:.6g} m/s")
    j = None
    if n > 1:
        d = x[:-1] - x[1:] + low.d0
        badc = np.flatnonzero(~np.isfinite(d))
        if badc.size:
            j = int(badc[0])
            parts.append(f"coupler {j + 1} (between vehicles {j + 1} and {j + 2}): "
                         f"deflection = {d[j]:.6g} m")
    parts.append("hint: reduce solver.dt (or bs23 tolerances), or check stiffness and damping "
                 "against the masses")
    return SimulationError("; ".join(parts), time=t, vehicle=i, coupler=j)


def _dataset(scenario: Scenario, low: Lowered, rec: dict, wall: float,
             compile_time: float) -> xr.Dataset:
    n = low.n
    n_rec = rec["s"].shape[0]
    keep = recorded(scenario)
    time = np.arange(n_rec) * (low.record_every * low.dt)
    p0 = low.p0
    position = rec["x"]  # the kernel records track positions
    vel = rec["v"]
    ref = low.speed_vehicle
    s = rec["s"]
    vdims = ("time", "vehicle")
    cdims = ("time", "coupler")
    data = {}
    if "x" in keep:
        data["position"] = (vdims, position)
    if "v" in keep:
        data["velocity"] = (vdims, vel)
    if "a" in keep:
        data["acceleration"] = (vdims, rec["a"])
    if "x" in keep:  # position - position[:, :1] - (p0 - p0[0]), with one temporary less
        rel = np.subtract(position, position[:, :1])
        rel -= p0 - p0[0]
        data["relative_position"] = (vdims, rel)
    if "v" in keep:
        data["relative_velocity"] = (vdims, vel - vel[:, :1])
    if "d" in keep:
        data["coupler_deflection"] = (cdims, rec["d"])
    if "f" in keep:
        data["coupler_force"] = (cdims, rec["f"])
    data.update({
        "traction_force": ("time", s[:, kernel.S_TRACTION]),
        "speed_reference": ("time", s[:, kernel.S_VREF]),
    })
    if "v" in keep:
        data["speed_error"] = ("time", s[:, kernel.S_VREF] - vel[:, ref])
    data.update({
        "adhesion_limit": ("time", s[:, kernel.S_ADHESION]),
        "demanded_acceleration": ("time", s[:, kernel.S_ADEM]),
        "traction_demand": ("time", s[:, kernel.S_DEMAND]),
    })
    coords = {
        "time": ("time", time),
        "vehicle": ("vehicle", np.arange(n)),
        "vehicle_name": ("vehicle", [v.name for v in scenario.vehicles]),
        "coupler": ("coupler", np.arange(n - 1)),
        # the numbers people read: vehicle 1 is the lead, coupler 1 joins vehicles 1 and 2
        "vehicle_number": ("vehicle", np.arange(1, n + 1)),
        "coupler_number": ("coupler", np.arange(1, n)),
    }
    nc = n - 1
    for col, name in ((kernel.PK_MAX, "max_coupler_force"), (kernel.PK_MIN, "min_coupler_force"),
                      (kernel.PK_TMAX, "time_max_coupler_force"),
                      (kernel.PK_TMIN, "time_min_coupler_force")):
        data[name] = ("coupler", rec["peaks"][:, col] if nc else np.zeros(0))
    if low.braked:
        data["brake_command"] = ("time", s[:, kernel.S_BRAKE])
        for key, name in (("b", "brake_force"), ("p", "brake_cylinder")):
            if key in keep:
                data[name] = (vdims, rec[key])
    if low.fluid:
        for key, name in (("bp", "brake_pipe_pressure"), ("ar", "auxiliary_reservoir_pressure"),
                          ("bc", "brake_cylinder_pressure")):
            if key in keep:
                data[name] = (vdims, rec[key])
        if "ax" in keep:
            data["air_exhausted"] = ("time", rec["ax"][:, 0])
    if rec["c"].shape[1]:
        data["locomotive_force"] = (("time", "locomotive"), rec["c"])
    if rec["c"].shape[1] or (low.drive_z.size and "m" in keep):
        coords["locomotive"] = ("locomotive", [c.name for c in scenario.consists()])
    if low.drive_z.size and "m" in keep:
        # per consist (NaN for one on the traction curve); per motor or per locomotive
        # as DESCRIPTIONS says
        for q, name in enumerate(DRIVE_SIGNALS):
            arr = np.full((n_rec, low.drive_of.size), np.nan)
            for c, kd in enumerate(low.drive_of):
                if kd >= 0:
                    arr[:, c] = rec["m"][:, kd, q]
            data[name] = (("time", "locomotive"), arr)
    if rec["e"].shape[1]:
        e = rec["e"]
        for q, name in enumerate(ENERGY_TERMS):
            data[name] = ("time", e[:, q])
        data["coupler_energy"] = (cdims, e[:, N_ENERGY:N_ENERGY + nc])
        data["kinetic_energy"] = ("time", e[:, -1])
        # every term but motoring is work taken from the train
        taken = (e[:, [q for q in range(N_ENERGY) if q != E_MOTOR]].sum(axis=1)
                 + e[:, N_ENERGY:N_ENERGY + nc].sum(axis=1))
        data["energy_balance_error"] = ("time", e[:, E_MOTOR] - taken - (e[:, -1] - e[0, -1]))
    ds = xr.Dataset(data, coords=coords)
    for name, unit in UNITS.items():
        if name in ds:
            ds[name].attrs["units"] = unit
            if name in DESCRIPTIONS:
                ds[name].attrs["long_name"] = DESCRIPTIONS[name]
    ds["coupler"].attrs["long_name"] = "coupler i joins vehicle i and i + 1 (0 = lead)"
    ds["vehicle"].attrs["long_name"] = "vehicle index, 0 = lead, front to rear"
    ds["vehicle_number"].attrs["long_name"] = "vehicle number as people count: 1 = lead, " \
                                              "front to rear (vehicle index + 1)"
    ds["coupler_number"].attrs["long_name"] = "coupler number as people count: coupler k " \
                                              "joins vehicles k and k + 1, 1 = behind the " \
                                              "lead (coupler index + 1)"
    from ltdsim import __version__

    ds.attrs.update({
        "title": f"ltdsim result: {scenario.name}" + (f" case {scenario.case}" if scenario.case else ""),
        "ltdsim_version": __version__,
        "scenario_name": scenario.name,
        "case": scenario.case or "",
        "solver_method": scenario.solver.method,
        "solver_dt_s": scenario.solver.dt,
        "steps": rec["steps"][0],
        "rejected_steps": rec["steps"][1],
        "brake_commands": rec["n_events"],
        "brake_model": scenario.brake.model,
        "wall_time_s": wall,
        "compile_time_s": compile_time,
        "scenario_json": json.dumps(scenario.to_dict()),
        "conventions": "SI units; coupler force + tension; vehicle index 0 (vehicle_number "
                       "1) is the lead; coupler index 0 (coupler_number 1) joins the lead "
                       "and the second vehicle",
    })
    if scenario.brake.model == "fluid" and scenario.solver.adaptive:
        # the pneumatic states' own steps (kernel.run_adaptive)
        ds.attrs["air_steps"] = rec["air_steps"][0]
        ds.attrs["air_rejected_steps"] = rec["air_steps"][1]
    if scenario.curving is not None:  # after the run, from the records (ltdsim.results.curving)
        from ltdsim.results.curving import add_curving

        ds = add_curving(ds, scenario)
    return ds
