"""A single draft gear tested: prescribed deflection, a mass driven by a force, a
wagon's impact, catalogue ratings.

The rig (:mod:`ltdsim.engine.rig`) runs the train kernel's own coupler code and stage
routine, so a gear behaves here exactly as it does in a train; every gear command and
the model reduction test a coupling (its ``gears`` in series included) through it.

* ``drive_deflection``: the gear deflection ``d(t)`` (and its rate) is prescribed; the
  gear's internal states are integrated; returns its force. This draws force-deflection
  loops.
* ``drive_force``: one end of the gear on a fixed wall, the other on a mass ``m``
  (kg) pushed by a force history ``F(t)`` (N, + pulls the gear into draft):
  ``m d'' = F(t) - T(d, d')``. This is the study's model-reduction rig (§3).
* ``impact``: a wagon running into a standing one, through the full train kernel.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from ltdsim.engine.rig import RIG_DEFLECTION, RIG_FORCE, _Run, run_rig
from ltdsim.scenario import CouplerParams, Scenario


def _dataset(run: _Run, **attrs) -> xr.Dataset:
    ds = xr.Dataset(
        {"deflection": ("time", run.deflection, {"units": "m", "long_name": "+ draft"}),
         "rate": ("time", run.rate, {"units": "m/s"}),
         "force": ("time", run.force, {"units": "N", "long_name": "+ tension"})},
        coords={"time": ("time", run.time, {"units": "s"})})
    ds.attrs.update(attrs)
    return ds


#: the rig's step of :func:`drive_deflection` unless told, s
DEFLECTION_DT = 1e-4


def rig_samples(duration: float, dt: float = DEFLECTION_DT) -> int:
    """Samples the rig records over ``duration`` seconds at step ``dt`` (it records every
    step, in four arrays: time, deflection, rate, force)."""
    return int(round(duration / dt)) + 1


def drive_deflection(params: CouplerParams, t, d, *, dt: float = DEFLECTION_DT,
                     method: str = "ode3") -> xr.Dataset:
    """Force of a gear whose deflection follows ``d(t)``.

    Parameters
    ----------
    params : CouplerParams
        The gear (any coupler model; e.g. ``CouplerParams(preset="friction-wedge-high")``).
    t, d : array
        Samples of time (s, increasing) and deflection (m, + draft); linear between
        samples, the rate is their finite difference.
    dt : float
        Integration step, s.

    Returns
    -------
    xarray.Dataset with ``deflection`` (m), ``rate`` (m/s), ``force`` (N) over ``time``.
    """
    t = np.asarray(t, dtype=float)
    d = np.asarray(d, dtype=float)
    rate = np.gradient(d, t)
    run = run_rig(params, RIG_DEFLECTION, t, d, rate, 1.0, t[-1] - t[0], dt, method)
    return _dataset(run, rig="prescribed deflection", model=params.model)


def drive_force(params: CouplerParams, t, force, *, mass: float, dt: float = 1e-4,
                method: str = "ode3") -> xr.Dataset:
    """A mass ``mass`` (kg) on a gear fixed at its other end, pushed by ``force(t)`` (N).

    ``t``/``force`` are samples, linear between them. Returns the gear's deflection,
    rate and force over time.
    """
    t = np.asarray(t, dtype=float)
    run = run_rig(params, RIG_FORCE, t, np.asarray(force, dtype=float), t * 0.0, mass,
                   t[-1] - t[0], dt, method)
    return _dataset(run, rig="mass on a gear, force driven", model=params.model, mass_kg=mass)


#: the study's model-reduction excitation (paper §3): (amplitude N, rad/s, duration s)
STUDY_SINES = ((1e6, np.pi / 2, 8.0), (1e6, np.pi, 4.0), (1e6, 2 * np.pi, 2.0),
               (1e7, 10 * np.pi, 0.4), (1e7, 20 * np.pi, 0.2))


def sine_chain(segments=STUDY_SINES, dt: float = 1e-4):
    """The study's model-reduction excitation (paper §3): sines of amplitude A (N) and
    angular frequency w (rad/s) for T seconds each, one after the other, each starting
    at phase 0 (14.6 s in all with the defaults). Returns samples ``(t, F)``."""
    ts, fs = [], []
    t0 = 0.0
    for amp, w, dur in segments:
        n = int(round(dur / dt))
        tt = np.arange(n) * dt
        ts.append(t0 + tt)
        fs.append(amp * np.sin(w * tt))
        t0 += dur
    ts.append([t0])
    fs.append([0.0])
    return np.concatenate(ts), np.concatenate(fs)


def loop_energy(ds: xr.Dataset) -> float:
    """Energy absorbed by the gear over the record, J: the integral of force times
    deflection rate (the signed area of the force-deflection loop)."""
    return float(np.trapezoid(ds.force.values * ds.rate.values, ds.time.values))


def series_range() -> tuple[int, int]:
    """The gears in series a coupling may have: the range of the coupler key ``gears``
    in the scenario schema (1 to 2)."""
    from ltdsim.scenario.couplers import _CouplerBase

    meta = _CouplerBase.model_fields["gears"].metadata
    return (int(next(m.ge for m in meta if hasattr(m, "ge"))),
            int(next(m.le for m in meta if hasattr(m, "le"))))


def table_from_ratings(travel: float, force: float, capacity: float, absorptivity: float, *,
                       preload: float = 0.0, points: int = 21, turn: float = 0.05,
                       series: int = 1) -> dict:
    """Loading and unloading tables of a gear known by its rated values only.

    Manufacturers and standards (AAR M-901, TB/T 2915) rate a draft gear by its travel,
    the force at that travel ("impedance" or reaction force), its capacity (the energy
    taken in closing it) and its absorptivity (the share of that energy it does not
    give back). This builds the simplest curves that reproduce all four:

    * loading ``f_l(x) = P + (F - P) (x / X)^n``, the exponent ``n`` chosen so that the
      table's area (trapezoids between its points, as the kernel interpolates) equals
      the capacity;
    * unloading a fixed share of loading, ``f_u = c f_l``, with ``c`` such that a slow
      release from full travel (first down the locked line, then along ``f_u``) gives
      back ``(1 - a)`` of the capacity, so a full closing and release absorbs ``a``
      times it;
    * ``k_locked`` such that the gear turns from loading to unloading at full travel
      within ``turn`` of its travel, or less where the energy it gives back on that
      line would exceed half of what it may give back at all (``turn <= a (1 - a)
      E / (F X)``).

    A connection between two wagons has a gear in each wagon's end, in series: with
    ``series = 2`` the coupler keys say so (``gears = 2``: the tables describe one gear,
    the coupling deflects twice as far at the same forces, with twice the travel and the
    capacity; ltdsim.engine.couplers.coupler_force).

    Parameters
    ----------
    travel : float
        Rated travel ``X``, m.
    force : float
        Force at the rated travel ``F``, N.
    capacity : float
        Energy to close the gear to its rated travel, J.
    absorptivity : float
        Share of the capacity absorbed in a closing and release ``a``, 0-1.
    preload : float
        Force at zero deflection ``P`` (pre-compression), N.
    points : int
        Table points (denser towards full travel, where the curve bends).
    turn : float
        Share of the travel over which the gear turns from loading to unloading.
    series : int
        Number of identical gears in series in the connection.

    Returns
    -------
    dict of coupler keys: ``model``, ``loading``, ``unloading`` (``[m, N]`` pairs, one
    gear), ``travel`` (m, one gear), ``k_locked`` (N/m), ``gears`` (``series``) and
    ``exponent`` (the ``n`` found, for reports; not a coupler key).
    """
    from scipy.optimize import brentq

    lo_s, hi_s = series_range()
    mean = capacity / travel if travel > 0.0 else np.nan
    checks = [
        (travel > 0.0, "travel", "must be > 0 m"),
        (force > 0.0, "force", "must be > 0 N"),
        (0.0 <= preload < force, "preload", f"must lie in [0, force = {force:g} N)"),
        (preload < mean < force, "capacity",
         f"must lie between preload x travel and force x travel "
         f"({preload * travel:g} to {force * travel:g} J)"),
        (0.0 < absorptivity < 1.0, "absorptivity", "must lie in (0, 1)"),
        (points >= 3, "points", "must be at least 3"),
        (0.0 < turn <= 1.0, "turn", "must lie in (0, 1]"),
        (lo_s <= series <= hi_s, "series", f"must be a whole number from {lo_s} to {hi_s} "
         "(the coupler key gears: gears in series in a coupling)"),
    ]
    for ok, key, why in checks:
        if not ok:
            raise ValueError(f"{key} {why}")
    x = travel * np.sqrt(np.linspace(0.0, 1.0, points))

    def loading(n):
        return preload + (force - preload) * (x / travel) ** n

    # the exponent n of the loading curve that closes with the capacity; the range of
    # n searched bounds the capacities a table of these points can hold (its root
    # finder's own words would mean nothing to whoever gave the ratings)
    n_lo, n_hi = 1e-6, 1e3
    most, least = (float(np.trapezoid(loading(k), x)) for k in (n_lo, n_hi))
    if not least < capacity < most:
        raise ValueError(f"capacity must lie between {least:.6g} and {most:.6g} J for this "
                         f"travel, force and preload (the loading curve a power of the "
                         f"deflection, exponent {n_lo:g} to {n_hi:g}, over {points} table "
                         f"points; got {capacity:.10g})")
    n = brentq(lambda n: np.trapezoid(loading(n), x) - capacity, n_lo, n_hi, xtol=1e-12)
    f_l = loading(n)
    # the locked line gives back about F^2 / (2 k_locked); keep that within half of
    # (1 - a) E so that an unloading curve can take the rest
    held = absorptivity * (1.0 - absorptivity) * capacity / (force * travel)
    asked, turn = turn, min(turn, held)
    k_locked = absorptivity * force / (turn * travel)
    k_max = _k_locked_max()
    if k_locked > k_max and held < asked:  # (a nearly perfect absorber: k = F^2/((1-a)E))
        a_max = 1.0 - force**2 / (k_max * capacity)
        raise ValueError(f"absorptivity must be at most {a_max:.6g} for this force and "
                         f"capacity: above it the gear's locked slope exceeds the {k_max:g} "
                         f"N/m a table gear's k_locked may have (got {absorptivity:.10g})")
    if k_locked > k_max:
        raise ValueError(f"force {force:g} N over a travel of {travel:g} m gives the "
                         f"gear a locked slope of {k_locked:.4g} N/m, above the {k_max:g} "
                         "N/m a table gear's k_locked may have: lower the force or give "
                         "a longer travel")
    # the unloading curve c f_l: c such that the release, first along the locked line
    # from full travel down to the curve and then along it, gives back (1 - a) capacity
    c_hi = 1.0 - 1e-9
    back = [_release_work(x, f_l, c, k_locked) / capacity for c in (0.0, c_hi)]
    if not back[0] <= 1.0 - absorptivity <= back[1]:
        raise ValueError(f"absorptivity must lie between {1.0 - back[1]:.6g} and "
                         f"{1.0 - back[0]:.6g} for these ratings (what the table's release "
                         "can give back, from along its locked line alone to along its whole "
                         f"loading curve; got {absorptivity:.10g})")
    c = brentq(lambda c: _release_work(x, f_l, c, k_locked) - (1.0 - absorptivity) * capacity,
               0.0, c_hi, xtol=1e-12)
    f_u = c * f_l
    return {
        "model": "table",
        "loading": [[float(a), float(b)] for a, b in zip(x, f_l)],
        "unloading": [[float(a), float(b)] for a, b in zip(x, f_u)],
        "travel": float(travel),
        "k_locked": float(k_locked),
        "gears": int(series),
        "exponent": float(n),
    }


def _k_locked_max() -> float:
    """The largest ``k_locked`` (N/m) the scenario schema allows a table gear."""
    from ltdsim.scenario.couplers import TableGear

    return float(next(m.le for m in TableGear.model_fields["k_locked"].metadata
                      if hasattr(m, "le")))


def _release_work(x, f_l, c, k_locked, steps: int = 4000) -> float:
    """Work (J) a table gear with loading ``f_l`` over ``x`` and unloading ``c f_l``
    gives back when released slowly from full travel: the force first falls along the
    locked slope ``k_locked + s_band`` (the band's slope between the curves, as the
    kernel's hysteresis law has it) until it meets the unloading curve, then follows it
    down to zero deflection."""
    slope = np.diff(f_l) / np.diff(x)
    xx = np.linspace(x[-1], 0.0, steps + 1)
    h = xx[0] - xx[1]
    f = f_l[-1]
    work = 0.0
    for k in range(steps):
        fl = np.interp(xx[k], x, f_l)
        fu = c * fl
        if f <= fu:  # on the unloading curve from here on
            tail = xx[k:][::-1]
            return work + float(np.trapezoid(c * np.interp(tail, x, f_l), tail))
        j = min(max(int(np.searchsorted(x, xx[k])) - 1, 0), len(slope) - 1)
        w = (f - fu) / (fl - fu) if fl > fu else 1.0
        s_band = slope[j] * (c + w * (1.0 - c))
        f_next = max(f - (k_locked + s_band) * h, c * np.interp(xx[k + 1], x, f_l))
        work += 0.5 * (f + f_next) * h
        f = f_next
    return work


def table_toml(gear: dict, *, slack: float = 0.0, comment: str = "") -> str:
    """TOML text of a ``table`` gear (from :func:`table_from_ratings`) as coupler keys,
    usable as a ``[couplers.default]`` body or as a gear preset file; ``comment`` lines
    go first, as TOML comments."""
    lines = [f"# {c}".rstrip() for c in comment.splitlines()]
    lines += ['model = "table"',
              f"slack = {slack!r:<20} # m, coupling free play",
              f"gears = {gear.get('gears', 1)!r:<20} # in series in the coupling",
              f"travel = {gear['travel']!r:<19} # m, one gear's",
              f"k_locked = {gear['k_locked']:<17.6g} # N/m"]
    for name in ("loading", "unloading"):
        lines.append(f"{name} = [  # [deflection m, force N]")
        lines += [f"    [{x:.6f}, {f:.1f}]," for x, f in gear[name]]
        lines.append("]")
    return "\n".join(lines) + "\n"


def impact_scenario(params: CouplerParams, speed: float, *, mass_moving: float = 90000.0,
                    mass_standing: float = 90000.0, dt: float = 1e-4, method: str = "ode3",
                    t_max: float = 2.0) -> Scenario:
    """The two-wagon scenario :func:`impact` runs: a wagon at ``speed`` (m/s) against a
    standing one, the coupling bunched, through gear ``params``."""
    return Scenario.from_dict({
        "name": "impact",
        "solver": {"method": method, "dt": dt, "t_end": t_max, "output_interval": dt},
        "vehicles": [{"name": "standing", "mass": mass_standing, "length": 15.0, "powered": True},
                     {"name": "moving", "mass": mass_moving, "length": 15.0}],
        "couplers": {"default": params.model_dump(exclude_none=True)},
        "traction": {"max_force": 1.0, "max_power": 1.0, "adhesion_mass": 1.0},
        "driver": {"mode": "force", "force_profile": [[0.0, 0.0]]},
        "initial": {"velocities": [0.0, float(speed)], "couplers": "bunched"},
    }, "impact")


def lightest_impact_mass(params: CouplerParams, *, dt: float = 1e-4, method: str = "ode3",
                         heaviest: float | None = None) -> float | None:
    """The lightest mass (kg, both wagons alike, 3 significant figures rounded up) at which
    :func:`impact`'s fixed step ``dt`` is stable for gear ``params``
    (:func:`ltdsim.engine.preflight.step_limit`: lighter wagons on the same gear ring
    faster). None when no mass up to ``heaviest`` (the schema's vehicle mass limit) is."""
    import math

    from ltdsim.engine.preflight import step_limit
    from ltdsim.scenario._base import MAX_MASS

    heaviest = MAX_MASS if heaviest is None else heaviest

    def stable(m: float) -> bool:
        lim = step_limit(impact_scenario(params, 1.0, mass_moving=m, mass_standing=m, dt=dt,
                                         method=method))
        return lim is None or lim.share <= 1.0

    if not stable(heaviest):
        return None
    lo, hi = heaviest * 1e-15, heaviest  # (lo unstable for any gear a train can have)
    if stable(lo):
        return lo
    for _ in range(60):  # bisection in log m
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if stable(mid) else (mid, hi)
        if hi / lo < 1 + 1e-4:
            break
    digits = 10 ** (math.floor(math.log10(hi)) - 2)
    up = math.ceil(hi / digits - 1e-9) * digits
    return min(float(f"{up:.3g}"), heaviest)


def impact(params: CouplerParams, speed: float, *, mass_moving: float = 90000.0,
           mass_standing: float = 90000.0, dt: float = 1e-4, method: str = "ode3",
           t_max: float = 2.0) -> dict:
    """A wagon at ``speed`` (m/s) runs into a standing wagon through gear ``params``.

    The wagons start touching (coupling bunched) and run until they separate again.
    Returns peak force (N), maximum gear deflection (m), kinetic energy lost (J), energy
    absorbed in the coupling (J, the integral of force times deflection rate), momentum
    before and after (kg m/s), and the dataset of the run.
    """
    from ltdsim.results.simulate import simulate

    sc = impact_scenario(params, speed, mass_moving=mass_moving, mass_standing=mass_standing,
                         dt=dt, method=method, t_max=t_max)
    ds = simulate(sc)
    f = ds.coupler_force.isel(coupler=0).values
    d = ds.coupler_deflection.isel(coupler=0).values
    v = ds.velocity.values
    m = np.array([mass_standing, mass_moving])
    # end of the impact: the first sample after the peak where the coupling is free again
    k_peak = int(np.argmax(np.abs(f)))
    free = np.flatnonzero(f[k_peak:] == 0.0)
    k_end = k_peak + int(free[0]) if free.size else len(f) - 1
    ke = 0.5 * (m * v**2).sum(axis=1)
    dd = v[:, 0] - v[:, 1]  # deflection rate
    # the wagons lose kinetic energy at the rate T * dd: that power goes into the coupling
    absorbed = float(np.trapezoid((f * dd)[:k_end + 1], ds.time.values[:k_end + 1]))
    momentum = v @ m
    return {
        "speed_m_s": speed,
        "peak_force_N": float(np.abs(f).max()),
        "max_deflection_m": float(np.abs(d).max()),
        "kinetic_energy_lost_J": float(ke[0] - ke[k_end]),
        "energy_absorbed_J": absorbed,
        "momentum_before": float(momentum[0]),
        "momentum_after": float(momentum[k_end]),
        "separated": bool(free.size),
        "dataset": ds.isel(time=slice(0, k_end + 1)),
    }
