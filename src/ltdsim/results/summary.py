"""Summary numbers of a result: what an engineer checks first."""

from __future__ import annotations

import math
import json

import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.results.io import scenario_of

#: m: rating travel of an AAR M-901 draft gear of 3-1/4 in (82.55 mm), the reference
#: against which gears without a stated travel (the study's simplified coupler) are checked
REFERENCE_TRAVEL = 0.083
#: m: the least deflection beyond its travel that counts a gear as beyond it (one
#: micrometre): below it the excess is the rounding of a gear at its travel, not travel
#: exceeded; above it a warning gives it to at least two significant figures
TRAVEL_RESOLUTION = 1e-6
#: rows per block in :func:`column_max` and :func:`column_min`
_BLOCK_ROWS = 64


def _by_column(ufunc: np.ufunc, x: np.ndarray) -> np.ndarray:
    """``ufunc.reduce(x, axis=0)`` for ``np.maximum`` or ``np.minimum`` over the rows of
    a 2-D array (time x couplers or vehicles): the same numbers (a maximum or minimum
    does not round, whatever the order), about ten times faster for a few columns and
    many rows. numpy reduces such an array a few elements (one row) at a time; here each
    block of :data:`_BLOCK_ROWS` rows is reduced as one long contiguous row first, then
    the blocks are reduced."""
    n, k = x.shape
    q = n // _BLOCK_ROWS * _BLOCK_ROWS
    if k == 0 or q == 0:
        return ufunc.reduce(x, axis=0)
    blocks = ufunc.reduce(np.ascontiguousarray(x[:q]).reshape(-1, _BLOCK_ROWS * k), axis=0)
    out = ufunc.reduce(blocks.reshape(_BLOCK_ROWS, k), axis=0)
    return ufunc(out, ufunc.reduce(x[q:], axis=0)) if q < n else out


def column_max(x: np.ndarray) -> np.ndarray:
    """Largest value of each column of 2-D ``x`` (``x.max(axis=0)``, faster), in x's unit."""
    return _by_column(np.maximum, x)


def column_min(x: np.ndarray) -> np.ndarray:
    """Smallest value of each column of 2-D ``x`` (``x.min(axis=0)``, faster), in x's unit."""
    return _by_column(np.minimum, x)


def coupler_summary(ds: xr.Dataset) -> pd.DataFrame:
    """Per coupler: largest tension and compression (N) and when they occur (s). The
    peaks are taken over every integration step where the result tracks them
    (``max_coupler_force`` etc.), else over the recorded samples."""
    if "time_max_coupler_force" in ds:
        top, low = ds.max_coupler_force.values, ds.min_coupler_force.values
        t_top, t_low = ds.time_max_coupler_force.values, ds.time_min_coupler_force.values
    else:  # a result written before the kernel tracked peaks
        f = ds.coupler_force
        t = ds.time.values
        top, low = f.max("time").values, f.min("time").values
        t_top, t_low = t[f.argmax("time").values], t[f.argmin("time").values]
    return pd.DataFrame({
        "coupler": ds.coupler.values,
        "max_tension_N": np.maximum(top, 0.0),
        "t_max_tension_s": t_top,
        "max_compression_N": np.maximum(-low, 0.0),
        "t_max_compression_s": t_low,
    }).set_index("coupler")


def critical_rows(table: pd.DataFrame, limit: int = 20) -> pd.DataFrame:
    """The whole coupler summary for short trains; for longer ones the ``limit`` couplers
    with the largest tension or compression, in coupler order."""
    if len(table) <= limit:
        return table
    worst = table[["max_tension_N", "max_compression_N"]].max(axis=1)
    return table.loc[worst.nlargest(limit).index].sort_index()


def run_summary(ds: xr.Dataset, scenario=None) -> dict[str, float]:
    """Scalar facts of a run: RMS and max speed error (m/s), max |acceleration| (m/s^2),
    peak traction (N), whether traction ever exceeded adhesion, the largest gear
    deflection beyond the slack (m) and how many couplers exceed their travel (or the
    reference travel, :func:`gear_travel_check`). What a run did not record
    (``solver.record``) is NaN, or left out for the gears. ``scenario`` is the one that
    made ``ds`` (by default read from the result)."""
    err = ds.speed_error.values if "speed_error" in ds else np.zeros(0)
    finite = np.isfinite(err)
    gears = {}
    if ((scenario is not None or "scenario_json" in ds.attrs) and ds.sizes.get("coupler", 0)
            and "coupler_deflection" in ds):
        table = gear_travel_check(ds, scenario)
        gears = {"max_gear_deflection_m": float(table.max_deflection_m.max()),
                 "couplers_beyond_travel": int(table.exceeds.sum())}
    return {
        "rms_speed_error_m_s": float(np.sqrt(np.mean(err[finite] ** 2))) if finite.any() else float("nan"),
        "max_speed_error_m_s": float(np.max(np.abs(err[finite]))) if finite.any() else float("nan"),
        "max_abs_acceleration_m_s2": float(np.abs(ds.acceleration.values).max())
        if "acceleration" in ds else float("nan"),
        "max_traction_N": float(ds.traction_force.max()),
        "max_brake_N": float(max(-ds.traction_force.min().item(), 0.0)),
        "max_air_brake_N": float(ds.brake_force.sum("vehicle").max()) if "brake_force" in ds
        else 0.0,
        "samples_over_adhesion": int((np.abs(ds.traction_force) > ds.adhesion_limit).sum()),
        "simulated_s": float(ds.time.values[-1]),
        "wall_time_s": float(ds.attrs.get("wall_time_s", float("nan"))),
        "compile_time_s": float(ds.attrs.get("compile_time_s", 0.0)),
        **gears,
    }


#: the lead vehicle counts as stopped below this speed, m/s (0.036 km/h): the air and
#: dynamic brakes and the Davis constant term fade out below about 0.01 m/s
STOP_SPEED = 0.01


def stopping(ds: xr.Dataset, stop_speed: float = STOP_SPEED) -> dict[str, float] | None:
    """Stopping distance and time of a run that brakes to a stop, else None.

    A run brakes to a stop when the lead vehicle's speed ends at or below ``stop_speed``
    (m/s) after the driver braked while it was moving. The brake application is the
    first recorded sample at which the driver brakes, an air-brake command above 0
    (``brake_command``) or a negative (dynamic-brake) traction demand, after the last
    sample at which traction was demanded (``traction_demand > 0``) before the stop;
    the stop is the moment the lead vehicle's speed last falls to ``stop_speed``
    (interpolated between samples). Times are resolved to the recording interval.

    Returns
    -------
    dict
        ``brake_time_s`` (the brake application), ``stop_time_s``, ``speed_m_s`` (the
        lead's speed at the brake application), ``stopping_time_s`` and
        ``stopping_distance_m`` (the lead vehicle's travel from the brake application to
        the stop).
    """
    if "velocity" not in ds or "position" not in ds:  # not recorded (solver.record)
        return None
    t = ds.time.values
    v = ds.velocity.values[:, 0]
    x = ds.position.values[:, 0]
    if t.size < 2 or abs(v[-1]) > stop_speed:
        return None
    moving = np.flatnonzero(np.abs(v) > stop_speed)
    if moving.size == 0 or moving[-1] == t.size - 1:
        return None
    k = int(moving[-1])  # last sample above the stop speed; the stop lies in (k, k + 1]
    v0, v1 = abs(v[k]), abs(v[k + 1])
    w = (v0 - stop_speed) / (v0 - v1) if v0 > v1 else 1.0
    t_stop = t[k] + w * (t[k + 1] - t[k])
    x_stop = x[k] + w * (x[k + 1] - x[k])
    demand = ds.traction_demand.values[: k + 1]
    braking = demand < 0.0
    if "brake_command" in ds:
        braking |= ds.brake_command.values[: k + 1] > 0.0
    pulling = np.flatnonzero(demand > 0.0)
    start = int(pulling[-1]) + 1 if pulling.size else 0
    applied = np.flatnonzero(braking[start:])
    if applied.size == 0:
        return None  # rolled to a stop on its resistance alone
    b = start + int(applied[0])
    if abs(v[b]) <= stop_speed:
        return None
    return {"brake_time_s": float(t[b]), "stop_time_s": float(t_stop),
            "speed_m_s": float(abs(v[b])), "stopping_time_s": float(t_stop - t[b]),
            "stopping_distance_m": float(abs(x_stop - x[b]))}


def speeds(ds: xr.Dataset) -> dict[str, float]:
    """The lead vehicle's largest and final speed, m/s."""
    v = ds.velocity.values[:, 0]
    return {"max_speed_m_s": float(np.abs(v).max()), "final_speed_m_s": float(v[-1])}


def gear_travel_check(ds: xr.Dataset, scenario=None,
                      reference_travel: float = REFERENCE_TRAVEL) -> pd.DataFrame:
    """How far each gear deflected beyond its coupling's slack, against its travel.

    A coupling of ``gears`` gears in series shares its deflection beyond the slack
    equally among them (:func:`ltdsim.engine.couplers.coupler_force`), so each gear
    deflects by that over ``gears``.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`ltdsim.simulate` (its recorded ``coupler_deflection``; peaks
        between recorded samples are not seen).
    scenario : Scenario, optional
        The scenario that made ``ds``; by default the one stored in the result.
    reference_travel : float
        Travel, m, for gears without a stated ``travel`` (the linear and simplified
        couplers unless one is given): default 0.083 m, an AAR M-901 gear of 3-1/4 in.

    Returns
    -------
    pandas.DataFrame
        Indexed by coupler (0 = between vehicles 0 and 1, as ``ds.coupler``):
        ``slack_m`` (total free play), ``gears`` (in series in the coupling),
        ``travel_m`` (one gear's travel, checked against),
        ``travel_stated`` (True if the coupler has its own ``travel``, False if the
        reference is used), ``max_draft_m`` and ``max_buff_m`` (largest deflection of one
        gear in draft and in buff, >= 0), ``max_deflection_m`` (the larger),
        ``excess_m`` (beyond the travel, >= 0) and ``exceeds`` (bool: an excess of
        more than :data:`TRAVEL_RESOLUTION`).
    """
    scenario = scenario_of(ds, scenario)
    d = ds.coupler_deflection.values
    nc = d.shape[1]
    params = [scenario.coupler(j) for j in range(nc)]
    half = 0.5 * np.array([c.slack for c in params])
    gears = np.array([c.gears for c in params], dtype=float)
    stated = np.array([c.travel is not None for c in params], dtype=bool)
    travel = np.array([c.travel if c.travel is not None else reference_travel for c in params])
    if d.shape[0]:
        draft = np.clip(column_max(d) - half, 0.0, None) / gears
        buff = np.clip(-column_min(d) - half, 0.0, None) / gears
    else:
        draft = buff = np.zeros(nc)
    largest = np.maximum(draft, buff)
    excess = np.clip(largest - travel, 0.0, None)
    return pd.DataFrame({
        "coupler": ds.coupler.values, "slack_m": 2.0 * half, "gears": gears.astype(int),
        "travel_m": travel,
        "travel_stated": stated, "max_draft_m": draft, "max_buff_m": buff,
        "max_deflection_m": largest, "excess_m": excess,
        "exceeds": excess > TRAVEL_RESOLUTION,
    }).set_index("coupler")


def travel_warning(ds: xr.Dataset, scenario=None,
                   reference_travel: float = REFERENCE_TRAVEL) -> str | None:
    """One line naming the couplers (counted from 1, coupler 1 behind the lead vehicle)
    whose gears deflected beyond their travel by more than :data:`TRAVEL_RESOLUTION`
    (see :func:`gear_travel_check`) and by how much, mm (two significant figures below
    10 mm); None when none did (or the run did not record coupler_deflection)."""
    if "coupler_deflection" not in ds:
        return None
    table = gear_travel_check(ds, scenario, reference_travel)
    over = table[table.exceeds]
    if over.empty:
        return None
    parts = [f"{j + 1} by {_mm(row.excess_m)}" for j, row in over.iterrows()]
    stated = over.travel_stated.all()
    reference = f"{reference_travel * 1e3:.0f} mm, a real gear's travel (AAR 3-1/4 in)"
    if stated:
        limit = "their stated travel"
    elif not over.travel_stated.any():
        limit = reference
    else:
        limit = f"their travel (stated, or {reference})"
    worst = over.max_deflection_m.max()
    return (f"gears deflect beyond {limit}: coupler{'s' if len(over) > 1 else ''} "
            f"{', '.join(parts)} (largest deflection beyond the slack {_mm(worst)})")


def _mm(x: float) -> str:
    """A length ``x`` (m) in millimetres as a warning prints it: whole millimetres from
    10 mm, else two significant figures (0.31 mm, never "0 mm" for a real excess)."""
    mm = x * 1e3
    return f"{mm:.0f} mm" if mm >= 9.5 else f"{mm:.2g} mm"


# ------------------------------------------------------------------ fluid air brake
#: Pa: a vehicle's brake pipe counts as reached by a brake application once it has
#: fallen this far (0.3 bar, about 4.4 psi) below its pressure before the command. The
#: one definition of the brake signal's arrival in ltdsim: the run summary and the tests
#: use it (docs/airbrake.md, "Propagation speed"). Below the smallest service reduction
#: a driver's valve makes (0.4-0.5 bar, both practices), so every application reaches it
#: at the lead; three times the drop at which the control valves begin to apply (0.1 bar,
#: the presets' ``threshold``), so a vehicle it has reached is applying, and deeper than
#: the small precursor the pipe alone carries ahead of the valves at sqrt(R T).
PIPE_DROP = 3.0e4

#: Pa gauge: a vehicle's brake pipe counts as vented (its own or a neighbour's emergency
#: vent open) once it has fallen below this pressure: a service application holds the
#: pipe at the full-service equalisation (3.5 bar UIC, 4.4 bar AAR), only a vent takes
#: it near the atmosphere. Its arrival times give the vent front's speed.
VENTED = 1.0e5

#: share of its final pressure at which a brake cylinder counts as applied (the UIC 540
#: application time runs to 95 % of the final cylinder pressure)
CYLINDER_SHARE = 0.95

#: Pa (gauge): a cylinder that ends an application below this pressure (0.1 bar) did
#: not apply; it gets no 95 % time
CYLINDER_APPLIED = 1.0e4

#: s and share: a cylinder counts as settled at the end of its application window when
#: its pressure changed by at most ``SETTLED_SHARE`` of its final value over the window's
#: last ``SETTLED_WINDOW`` seconds (for an exponential fill of time constant tau this
#: leaves a gap to the true final pressure of at most 0.5 % / (exp(5 s / tau) - 1), 0.6 %
#: for the 8 s of a goods-timed valve). An unsettled cylinder's 95 % time is a lower
#: bound and is reported so.
SETTLED_WINDOW = 5.0
SETTLED_SHARE = 0.005


def brake_control_vehicles(ds: xr.Dataset) -> list[int]:
    """Vehicle indices (0 = lead) of the brake-control points of the run that made ``ds``:
    the lead consist's first vehicle and the first vehicle of every other locomotive
    consist with ``brake_control = true`` (their driver's valves vent and charge the
    pipe). Without the scenario in the result, the lead alone."""
    if "scenario_json" not in ds.attrs:
        return [0]

    sc = scenario_of(ds)
    consists = sc.consists()
    if not consists:
        return [0]
    points = [int(consists[0].vehicles[0])]
    points += [int(c.vehicles[0]) for c in consists[1:] if c.brake_control]
    return points


def _crossing(t: np.ndarray, x: np.ndarray, level: float, start: int, below: bool) -> float:
    """First time at or after sample ``start`` at which ``x`` reaches ``level`` (falling to
    it if ``below``, else rising to it), linear between samples; NaN if it never does."""
    seg = x[start:]
    hit = seg <= level if below else seg >= level
    k = np.flatnonzero(hit)
    if k.size == 0:
        return float("nan")
    k = int(k[0]) + start
    if k == 0 or not (x[k - 1] > level if below else x[k - 1] < level):
        return float(t[k])  # reached already at the first sample looked at
    x0, x1 = x[k - 1], x[k]
    w = (x0 - level) / (x0 - x1) if x0 != x1 else 1.0
    return float(t[k - 1] + w * (t[k] - t[k - 1]))


def _wave_starts_near(arrival: np.ndarray, c: int, reach: int = 5) -> bool:
    """Whether a pipe drop started at or near vehicle ``c``: the arrival times (s) of
    the vehicles within ``reach`` of it have their least value inside that stretch (a V),
    not at its end (a wave passing through arrives in order, front to rear or rear to
    front). The earliest arrival may lie a few vehicles from ``c``: its driver's valve
    feeds one pipe cell, and in a service reduction the wagons' valves near it draw the
    pipe down (quick service) before its own, valveless, locomotives see it."""
    n = arrival.size
    lo, hi = max(c - reach, 0), min(c + reach + 1, n)
    near = arrival[lo:hi]
    if not np.isfinite(near).all():
        return False
    m = lo + int(np.argmin(near))
    return (m > lo or lo == 0) and (m < hi - 1 or hi == n)


def _fit_waves(x0: np.ndarray, sources: list[int], arrival: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Least-squares fit of arrival (s) against distance (m) with one slope and one
    intercept per wave: ``x0`` vehicle positions (m), ``sources`` vehicle indices, front
    to rear. The waves come from the arrivals themselves: between two neighbouring
    sources the last vehicle to be reached (the latest arrival) is where their waves
    meet; the vehicles from the front source to it belong to that source's rearward
    wave, those behind it to the rear source's forward wave; the vehicles ahead of the
    first source to its forward wave, those behind the last to its rearward wave. The
    meeting vehicles stay out of the fit (two waves reach them together) and then join
    the wave whose fitted line reaches them first.
    Returns (distance of each vehicle from its wave's source m, wave of each vehicle =
    2 x position in ``sources`` + 1 for a rearward wave, speed m/s, RMS of the residuals
    s); speed and RMS NaN when the arrivals cannot give a slope."""
    n = x0.size
    order = sorted(sources)
    src = np.empty(n, dtype=np.int64)  # position in ``order`` of each vehicle's source
    src[:order[0]] = 0
    meets = []
    for k, (a, b) in enumerate(zip(order, order[1:])):
        seg = arrival[a:b + 1]
        meet = a + (int(np.nanargmax(seg)) if np.isfinite(seg).any() else (b - a) // 2)
        src[a:meet + 1] = k
        src[meet + 1:b] = k + 1
        meets.append(meet)
    src[order[-1]:] = len(order) - 1
    at = np.asarray(order)[src]
    behind = np.arange(n) >= at
    dist = np.abs(x0 - x0[at])
    wave = 2 * src + behind
    ok = np.isfinite(arrival)
    ok[meets] = False  # reached by two waves at once, and either may have come first
    groups = np.unique(wave[ok])
    if not (ok.sum() > groups.size and np.ptp(dist[ok]) > 0.0):
        return dist, wave, float("nan"), float("nan")
    design = np.column_stack([dist[ok]] + [(wave[ok] == g).astype(float) for g in groups])
    coef, *_ = np.linalg.lstsq(design, arrival[ok], rcond=None)
    speed = 1.0 / coef[0] if coef[0] > 0.0 else float("nan")
    rms = float(np.sqrt(np.mean((arrival[ok] - design @ coef) ** 2)))
    icept = dict(zip(groups.tolist(), coef[1:]))
    for k, m in enumerate(meets):  # the wave whose line reaches the meeting vehicle first
        first = [(icept[g] + coef[0] * abs(x0[m] - x0[order[j]]), g, j)
                 for g, j in ((2 * k + 1, k), (2 * (k + 1), k + 1)) if g in icept]
        if first:
            _, wave[m], j = min(first)
            dist[m] = abs(x0[m] - x0[order[j]])
    return dist, wave, float(speed), rms


def _application_window(ds: xr.Dataset, pipe: np.ndarray, lead: int, threshold: float,
                        command_time: float | None) -> tuple[int, int, int, float] | None:
    """(first sample, end sample exclusive, sample of the pipe pressures before the
    application, command time s) of the first brake application in the record (see
    :func:`fluid_brake_summary`), or None without one."""
    t = ds.time.values
    if command_time is None and "brake_command" in ds:
        cmd = np.nan_to_num(ds.brake_command.values)
        rise = np.flatnonzero(np.diff(cmd) > 0.0) + 1
        if cmd.size and cmd[0] > 0.0:
            rise = np.concatenate(([0], rise))
        if rise.size:
            command_time = float(t[rise[0]])
    if command_time is None:  # the pipe at the brake-control point tells
        drop = np.flatnonzero(pipe[:, lead] <= pipe[0, lead] - threshold)
        if drop.size == 0:
            return None
        command_time = _crossing(t, pipe[:, lead], pipe[0, lead] - threshold, 0, True)
        start, ref = max(int(drop[0]) - 1, 0), 0  # the pipe as charged at the start
    else:
        start = int(np.searchsorted(t, command_time, side="right")) - 1
        start = min(max(start, 0), t.size - 1)
        ref = max(start - 1, 0)  # the last sample before the command was seen
    end = t.size
    if "brake_command" in ds:
        cmd = np.nan_to_num(ds.brake_command.values)
        later = np.flatnonzero(cmd[start + 1:] < cmd[start:-1]) + start + 1
        if later.size:
            end = int(later[0])  # the first release (or lesser command) after it
    return start, end, ref, float(command_time)


def fluid_brake_summary(ds: xr.Dataset, threshold: float = PIPE_DROP,
                        command_time: float | None = None,
                        control_points: list[int] | None = None) -> dict | None:
    """Propagation of the first brake application along the train and the filling of
    the cylinders, for a run with the fluid brake (``brake_pipe_pressure`` and
    ``brake_cylinder_pressure`` in ``ds``, time x vehicle, Pa gauge); None for another
    run or one without an application.

    **The application** starts at ``command_time`` (s): by default the first recorded
    sample at which ``brake_command`` rises, else the moment the pipe at the lead's
    brake-control point has fallen ``threshold``. It lasts until the command next falls
    (a release) or the record ends. Times are resolved to the recording interval
    (``solver.output_interval``), crossings interpolated linearly between samples.

    **Arrival** at vehicle i: the first moment after the command at which the pipe
    pressure at that vehicle has fallen ``threshold`` (Pa, default :data:`PIPE_DROP`,
    0.2 bar) below its value before the command (the last sample before it).

    **Distance** of vehicle i: along the train from the brake-control point whose wave
    reaches it (see below; the nearest one unless a remote point vents late) among
    those that vented (``control_points``, vehicle indices, default
    :func:`brake_control_vehicles`; a remote point counts only if the earliest arrival
    among the vehicles within five of it lies inside that stretch, i.e. if a wave started
    there rather than passed through: a remote point that vents so late that the lead's
    wave is within five vehicles of it by then is not told from a passing wave), |x_i -
    x_c| between vehicle centres at the start of the record, m.

    **Propagation speed** (m/s): the inverse of the slope of arrival time against
    distance, fitted by least squares to every vehicle the application reached, one
    slope for the whole train and one intercept per wave (each source and direction:
    ahead of a remote point and behind it are two waves; between two sources the
    vehicle reached last is where their waves meet, and each vehicle belongs to the wave
    on its side of that point). A slope, not one vehicle's
    time, because (1) the delay at a source (the driver's valve opening, the time the
    pipe there takes to fall by ``threshold``, a remote point's own delay, where along
    its vehicle the valve feeds the pipe) is the same for every vehicle of its wave and
    drops out of a slope but not of a ratio distance / time; (2) it uses every vehicle,
    so one arrival's sampling error (up to an output interval) does not set it. It is the speed at which the pipe drop travels along the train, the
    quantity UIC 540 bounds from below (250 m/s for an emergency application). The RMS
    of the fit's residuals (s) says how straight the arrivals lie: a service wave that
    slows down along the train shows as a large residual.

    **End to end** (ltdsim's propagation speed, the one the tests bound and ``ltdsim
    run`` prints first): the time from the command until the arrival at the farthest
    vehicle (from its brake-control point), s, and that distance over that time, m/s;
    it includes the delay at the source, as the railways' figure does.

    **Vent front**: the same, end to end, for the pipe falling below :data:`VENTED`
    (gauge): how fast the emergency vents open along the train; NaN when the pipe at the
    farthest vehicle never fell that far (a service application).

    **Cylinder times**: for each braked vehicle whose cylinder ends the application above
    :data:`CYLINDER_APPLIED`, the time from the command until its pressure first reaches
    :data:`CYLINDER_SHARE` (95 %) of its final pressure, the pressure at the end of the
    application, s. Given for the last braked vehicle (the rear) and the slowest one.
    ``*_settled`` is False when that cylinder still moved at the end of the record
    (:data:`SETTLED_WINDOW`, :data:`SETTLED_SHARE`): its final pressure and 95 % time are
    then lower bounds of the settled ones.

    Returns
    -------
    dict or None
        ``command_time_s``, ``end_time_s`` (end of the application window),
        ``threshold_Pa``, ``sources`` (vehicle indices of the brake-control points that
        vented), ``control_pipe_drop_Pa`` (the pipe's fall at the first source by the
        end of the window: about 5 bar in an emergency), ``vehicles_reached``,
        ``propagation_speed_m_s``, ``propagation_fit_rms_s``, ``farthest_vehicle``
        (index), ``farthest_distance_m``, ``propagation_time_s``,
        ``end_to_end_speed_m_s``, ``vent_time_s``, ``vent_front_speed_m_s``,
        ``vent_arrival_s`` (array), ``last_vehicle`` (index of the rear braked vehicle),
        ``last_cylinder_final_Pa`` (gauge), ``last_cylinder_95_s``,
        ``last_cylinder_settled``, ``slowest_vehicle``, ``slowest_cylinder_95_s``,
        ``slowest_cylinder_settled``, ``arrival_s`` and ``cylinder_95_s`` (arrays over
        vehicles, NaN where not reached or not braked), ``distance_m`` (array).
    """
    if any(k not in ds for k in ("brake_pipe_pressure", "brake_cylinder_pressure", "position")):
        return None
    t = ds.time.values
    if t.size < 2:
        return None
    pipe = ds.brake_pipe_pressure.values
    cyl = ds.brake_cylinder_pressure.values
    n = pipe.shape[1]
    points = brake_control_vehicles(ds) if control_points is None else list(control_points)
    points = [int(c) for c in points if 0 <= int(c) < n] or [0]
    window = _application_window(ds, pipe, points[0], threshold, command_time)
    if window is None:
        return None
    start, end, k_ref, t_cmd = window
    tw, pw, cw = t[:end], pipe[:end], cyl[:end]
    ref = pipe[k_ref]
    arrival = np.array([_crossing(tw, pw[:, i], ref[i] - threshold, start + 1, True)
                        if start + 1 < end else np.nan for i in range(n)])
    x0 = ds.position.values[0]
    sources = [points[0]] + [c for c in points[1:] if _wave_starts_near(arrival, c)]
    ok = np.isfinite(arrival)
    dist, _, speed, rms = _fit_waves(x0, sources, arrival)
    out: dict = {"command_time_s": t_cmd, "end_time_s": float(tw[-1]), "threshold_Pa": threshold,
                 "sources": sources,
                 "control_pipe_drop_Pa": float(ref[sources[0]] - pw[-1, sources[0]]),
                 "vehicles_reached": int(ok.sum()), "arrival_s": arrival - t_cmd,
                 "distance_m": dist}
    far = int(np.argmax(dist))
    out.update({"propagation_speed_m_s": float(speed), "propagation_fit_rms_s": rms,
                "farthest_vehicle": far, "farthest_distance_m": float(dist[far]),
                "propagation_time_s": float(arrival[far] - t_cmd)})
    out["end_to_end_speed_m_s"] = (float(dist[far] / out["propagation_time_s"])
                                   if out["propagation_time_s"] > 0.0 else float("nan"))
    # the vent front: each vehicle's pipe falling below VENTED (gauge), end to end
    vent_at = np.array([_crossing(tw, pw[:, i], VENTED, start + 1, True)
                        if start + 1 < end else np.nan for i in range(n)])
    out["vent_arrival_s"] = vent_at - t_cmd
    t_vent = float(vent_at[far] - t_cmd)
    out["vent_time_s"] = t_vent
    out["vent_front_speed_m_s"] = (float(dist[far] / t_vent) if t_vent > 0.0
                                   else float("nan"))

    t95 = np.full(n, np.nan)
    settled = np.zeros(n, dtype=bool)
    final = np.full(n, np.nan)
    tail = tw >= tw[-1] - SETTLED_WINDOW
    for i in range(n):
        c = cw[:, i]
        if not np.isfinite(c[start:]).all():
            continue  # an unbraked vehicle (NaN cylinder)
        final[i] = c[-1]
        if final[i] < CYLINDER_APPLIED:
            continue
        t95[i] = _crossing(tw, c, CYLINDER_SHARE * final[i], start, False) - t_cmd
        settled[i] = bool(np.ptp(c[tail]) <= SETTLED_SHARE * final[i])
    braked = np.flatnonzero(np.isfinite(final))
    applied = np.flatnonzero(np.isfinite(t95))
    last = int(braked[-1]) if braked.size else -1
    slow = int(applied[np.argmax(t95[applied])]) if applied.size else -1
    out.update({
        "last_vehicle": last,
        "last_cylinder_final_Pa": float(final[last]) if last >= 0 else float("nan"),
        "last_cylinder_95_s": float(t95[last]) if last >= 0 else float("nan"),
        "last_cylinder_settled": bool(settled[last]) if last >= 0 else False,
        "slowest_vehicle": slow,
        "slowest_cylinder_95_s": float(t95[slow]) if slow >= 0 else float("nan"),
        "slowest_cylinder_settled": bool(settled[slow]) if slow >= 0 else False,
        "cylinder_95_s": t95,
    })
    return out


def curving_summary(ds: xr.Dataset) -> dict | None:
    """The worst places of a run with curving indicators (``[curving]``), else None:
    the largest wheel L/V (-) with its vehicle number (1 = lead), time (s) and chainage
    (m, the vehicle centre), against Nadal's limit; the largest leading-wheelset lateral
    force (N) against the vehicle's Prud'homme limit; the largest coupler angle (rad)
    with its coupler number; the largest inward and outward lateral coupler components
    (N). Where a flanging wheel unloads fully (its L/V undefined: wheel lift, beyond
    any L/V limit) also ``wheel_lift_vehicles`` (how many vehicles lift a wheel) and
    the first lift's ``wheel_lift_vehicle``, ``wheel_lift_time_s`` and
    ``wheel_lift_position_m``; ``max_l_over_v`` is then the worst L/V of the wheels
    that keep load (NaN if none does). :func:`l_over_v_text` words it."""
    if "wheel_l_over_v" not in ds:
        return None
    lv = ds.wheel_l_over_v.values
    t = ds.time.values
    # a flanging wheel the roll moment unloads fully has no L/V (safety.py stores inf):
    # wheel lift, reported as such; the worst L/V is that of the wheels with load
    lifted = np.isposinf(lv)
    finite = np.where(np.isfinite(lv), lv, -np.inf)
    k, i = np.unravel_index(int(np.argmax(finite)), lv.shape)
    worst = float(lv[k, i]) if np.isfinite(lv[k, i]) else math.nan
    h = ds.wheelset_lateral_force.values
    ratio = h / ds.prudhomme_limit.values[None, :]
    kh, ih = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    out = {
        "max_l_over_v": worst,
        "l_over_v_vehicle": int(i) + 1,
        "l_over_v_time_s": float(t[k]),
        "l_over_v_position_m": float(ds.position.values[k, i]),
        "nadal_limit": float(ds.nadal_limit),
        "l_over_v_share_of_limit": worst / float(ds.nadal_limit),
        "max_wheelset_force_N": float(h[kh, ih]),
        "wheelset_force_vehicle": int(ih) + 1,
        "wheelset_force_time_s": float(t[kh]),
        "prudhomme_limit_N": float(ds.prudhomme_limit.values[ih]),
        "wheelset_force_share_of_limit": float(ratio[kh, ih]),
    }
    if lifted.any():  # the first record with a lift, its first vehicle
        kl = int(np.argmax(lifted.any(axis=1)))
        il = int(np.argmax(lifted[kl]))
        out.update({
            "wheel_lift_vehicles": int(lifted.any(axis=0).sum()),
            "wheel_lift_vehicle": il + 1,
            "wheel_lift_time_s": float(t[kl]),
            "wheel_lift_position_m": float(ds.position.values[kl, il]),
        })
    if ds.sizes.get("coupler", 0):
        a = ds.coupler_angle.values
        ka, ja = np.unravel_index(int(np.argmax(a)), a.shape)
        lat = ds.coupler_lateral_force.values
        out.update({
            "max_coupler_angle_rad": float(a[ka, ja]),
            "coupler_angle_coupler": int(ja) + 1,
            "coupler_angle_time_s": float(t[ka]),
            # (abs: a signed zero of the records would print as "-0.0 kN")
            "max_inward_coupler_force_N": abs(float(max(lat.max(), 0.0))),
            "max_outward_coupler_force_N": abs(float(max(-lat.min(), 0.0))),
        })
        lim = json.loads(ds.attrs.get("scenario_json", "{}")).get("curving") or {}
        stop = lim.get("coupler_angle_limit")
        if stop:
            out["couplers_at_stops"] = int((a >= stop).any(axis=0).sum())
    return out


def l_over_v_text(c: dict) -> str:
    """The worst wheel L/V of a :func:`curving_summary` ``c`` in words, with its place:
    "worst wheel L/V 0.812 (72 % of Nadal's 1.128) at vehicle 3, 4.5 s, chainage 120 m",
    or where a wheel lifts "wheel lift: ..." first (an L/V there is undefined, not
    infinite), then the worst L/V of the wheels that keep load."""
    place = (f"at vehicle {c['l_over_v_vehicle']}, {c['l_over_v_time_s']:.1f} s, "
             f"chainage {c['l_over_v_position_m']:.0f} m")
    worst = (f"{c['max_l_over_v']:.3f} ({100 * c['l_over_v_share_of_limit']:.0f} % of "
             f"Nadal's {c['nadal_limit']:.3f}) {place}")
    if "wheel_lift_vehicle" not in c:
        return f"worst wheel L/V {worst}"
    n = c["wheel_lift_vehicles"]
    lift = (f"wheel lift: the flanging wheel of vehicle {c['wheel_lift_vehicle']} unloads "
            f"fully at {c['wheel_lift_time_s']:.1f} s, chainage "
            f"{c['wheel_lift_position_m']:.0f} m (L/V undefined, beyond Nadal's limit "
            f"{c['nadal_limit']:.3f}; {n} vehicle{'s' if n > 1 else ''} lift a wheel)")
    if not math.isfinite(c["max_l_over_v"]):
        return lift
    return f"{lift}; worst L/V of the loaded wheels {worst}"


#: J per kWh
KWH = 3.6e6


def energy_summary(ds: xr.Dataset, scenario=None) -> dict | None:
    """Where the energy of a run went (``solver.energy = true``), else None.

    Returns a dict, J unless named otherwise: each work term at the end of the run
    (``traction_energy`` motoring at the rail, ``dynamic_brake_energy`` the work the
    dynamic brake took back, the most it can regenerate, ``air_brake_energy``,
    ``davis_energy``, ``grade_energy`` the potential energy gained, ``curve_energy``),
    ``coupler_energy`` (the couplers' net work, all of them), ``gear_stored`` (what they
    store at the end, :func:`ltdsim.engine.couplers.stored_energy`; NaN when the run did
    not record coupler_deflection), ``gear_dissipated`` (the difference),
    ``kinetic_change`` (kinetic energy at the end less at the start), ``balance_error``
    (what the integration leaves unaccounted at the end) and ``largest_balance_error``
    (over the run), ``throughput`` (motoring plus dynamic braking) and
    ``balance_error_share`` (the largest error over it, -); ``distance_m`` (the lead
    vehicle's, m), ``gross_tonnes`` (the train's static mass, t), and where the train
    moved, ``traction_kwh_per_km`` and ``traction_wh_per_gross_tonne_km`` (motoring
    energy at the rail per km and per gross tonne-km).
    """
    if "traction_energy" not in ds:
        return None
    scenario = scenario_of(ds, scenario)
    from ltdsim.engine.couplers import stored_energy
    from ltdsim.engine.layout import ENERGY_TERMS

    out = {k: float(ds[k].values[-1]) for k in ENERGY_TERMS}
    gears = ds.coupler_energy.values[-1] if ds.sizes.get("coupler", 0) else np.zeros(0)
    out["coupler_energy"] = float(gears.sum())
    if "coupler_deflection" in ds:
        d = ds.coupler_deflection.values[-1]
        stored = sum(stored_energy(scenario.coupler(j), float(d[j])) for j in range(d.size))
    else:
        stored = float("nan")
    out["gear_stored"] = float(stored)
    out["gear_dissipated"] = out["coupler_energy"] - out["gear_stored"]
    kin = ds.kinetic_energy.values
    out["kinetic_change"] = float(kin[-1] - kin[0])
    err = ds.energy_balance_error.values
    out["balance_error"] = float(err[-1])
    out["largest_balance_error"] = float(np.max(np.abs(err)))
    out["throughput"] = out["traction_energy"] + out["dynamic_brake_energy"]
    out["balance_error_share"] = (out["largest_balance_error"] / out["throughput"]
                                  if out["throughput"] > 0.0 else float("nan"))
    out["gross_tonnes"] = sum(v.weight_mass for v in scenario.vehicles) / 1e3
    dist = float(ds.position.values[-1, 0] - ds.position.values[0, 0]) if "position" in ds \
        else float("nan")
    out["distance_m"] = dist
    km = abs(dist) / 1e3
    moved = km > 1e-3
    out["traction_kwh_per_km"] = out["traction_energy"] / KWH / km if moved else float("nan")
    out["traction_wh_per_gross_tonne_km"] = (out["traction_energy"] / 3.6e3
                                             / (km * out["gross_tonnes"])
                                             if moved else float("nan"))
    return out
