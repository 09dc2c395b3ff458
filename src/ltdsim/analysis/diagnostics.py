"""Why a speed-controlled run rings: the numbers behind docs/paper-scenario.md, "Why the
base run rang".

A speed controller that holds the locomotive's speed tightly makes it a moving wall for
the wagons behind it. Their chain then rings in its lowest mode (wagons against the held
locomotive) with only the couplers' own damping, and the locomotive's force mirrors the
first coupler's. What sets the ringing off is any sudden change of the demanded
acceleration: a corner in the reference speed profile, or the slack running in.

:func:`base_run_diagnostics` measures this on a result; :func:`closed_loop_modes` gives
the linearised train's modes with the controller closed around it; :func:`oscillation`
is the measurement of one signal's swing and period; :func:`hunt_figure` draws it.
"""

from __future__ import annotations


import numpy as np
import pandas as pd
import xarray as xr

from ltdsim.scenario import Scenario

from ltdsim.results.io import scenario_of

#: Overrides that turn scenarios/paper.toml back into the reading ltdsim used before:
#: a reference profile with sharp corners (0.8 m/s^2 from rest to 16.72 m/s at 20.9 s,
#: 0.572 m/s^2 over 120-130 s), the track positions that go with it, and the PID output
#: multiplied by the train's mass. With it the base run rings at cruise; see
#: docs/paper-scenario.md and :func:`hunt_figure`.
PAPER_EARLIER_READING = {
    "driver.speed_profile": [[0.0, 0.0], [20.9, 16.72], [120.0, 16.72], [130.0, 11.0],
                             [270.0, 11.0]],
    "driver.pid.acceleration_of": "train",
    "track.curve": [[0.0, 0.0], [1079.3, 300.0], [2575.3, 0.0]],
    "track.gradient": [[0.0, 0.0], [2245.3, 0.005], [3015.3, 0.0]],
}


def oscillation(t, x, f_min: float | None = None, f_max: float = 10.0) -> dict[str, float]:
    """Swing and period of the oscillation in ``x(t)`` (any unit U; ``t`` in s, evenly
    sampled).

    The dominant frequency is the peak of the spectrum of ``x`` less its least-squares
    straight line (Hann window, zero-padded 16 times, refined by a parabola through the
    three highest bins). The swing is then measured on ``x`` less its centred moving
    average over one period of that frequency, which removes a steady value and any
    drift that is straight over a period, and leaves a sine whole; the first and last
    half period, where the average is not defined, are left out.

    Parameters
    ----------
    t : array, s
    x : array, U
    f_min, f_max : float, Hz
        Band searched for the dominant frequency; ``f_min`` defaults to two cycles in
        the record.

    Returns
    -------
    dict
        ``amplitude`` (U): half the peak-to-peak of the oscillating part; ``rms`` (U): its
        RMS (amplitude / sqrt 2 for a sine); ``frequency_hz`` (Hz) and ``period_s`` (s)
        of the dominant oscillation; ``mean`` (U) of ``x``.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if t.size < 8:
        raise ValueError("oscillation needs at least 8 samples")
    dt = float((t[-1] - t[0]) / (t.size - 1))
    r = x - np.polyval(np.polyfit(t - t[0], x, 1), t - t[0])
    n = r.size
    nfft = 1 << int(np.ceil(np.log2(16 * n)))
    spec = np.abs(np.fft.rfft(r * np.hanning(n), nfft))
    f = np.fft.rfftfreq(nfft, dt)
    lo = 2.0 / (n * dt) if f_min is None else f_min
    band = np.flatnonzero((f >= lo) & (f <= f_max))
    if band.size < 3:
        raise ValueError(f"no frequencies between {lo:.3g} and {f_max:.3g} Hz in the record")
    k = band[np.argmax(spec[band])]
    fp = f[k]
    if 0 < k < spec.size - 1:  # parabola through the log magnitudes of the three bins
        a, b, c = np.log(spec[k - 1:k + 2] + 1e-300)
        den = a - 2 * b + c
        if den < 0.0:
            fp += 0.5 * (a - c) / den * (f[1] - f[0])
    w = max(int(round(1.0 / (fp * dt))), 1)
    if w >= n:
        raise ValueError("the record is shorter than one period of its oscillation")
    c = np.concatenate([[0.0], np.cumsum(x)])
    avg = (c[w:] - c[:-w]) / w  # mean of x[i:i + w], centred at i + (w - 1) / 2
    osc = x[w // 2:w // 2 + avg.size] - avg if w % 2 else \
        0.5 * (x[w // 2 - 1:w // 2 - 1 + avg.size] + x[w // 2:w // 2 + avg.size]) - avg
    return {"amplitude": 0.5 * float(osc.max() - osc.min()),
            "rms": float(np.sqrt(np.mean(osc * osc))),
            "frequency_hz": float(fp), "period_s": float(1.0 / fp), "mean": float(np.mean(x))}


def cruise_window(ds: xr.Dataset, settle: float = 10.0) -> tuple[float, float]:
    """The longest stretch (s, s) over which the speed reference is constant and above
    zero, starting ``settle`` s after the reference levels off (the first swing after a
    change is the response to it, not yet the ringing)."""
    v = ds.speed_reference.values
    t = ds.time.values
    if not np.isfinite(v).any():
        raise ValueError("the result has no speed reference (the driver is not in speed mode)")
    flat = np.isfinite(v) & (v > 0.0)
    flat[1:] &= np.abs(np.diff(v)) <= 1e-9 * np.maximum(np.abs(v[1:]), 1.0)
    flat[0] = False
    best, start = (0.0, 0.0), None
    for k in range(t.size + 1):
        on = k < t.size and flat[k]
        if on and start is None:
            start = k
        elif not on and start is not None:
            a, b = t[start - 1], t[k - 1]
            if b - a > best[1] - best[0]:
                best = (float(a), float(b))
            start = None
    a, b = best
    if b - a <= settle:
        raise ValueError("the speed reference holds no constant speed for longer than "
                         f"{settle:g} s")
    return a + settle, b


def reference_corners(profile) -> pd.DataFrame:
    """Where the piecewise-linear speed reference ``[[t s, v m/s], ...]`` changes its
    slope: time (s) and the jump of the demanded acceleration there (m/s^2), largest
    first. (A rounded profile, :func:`ltdsim.engine.lowering.rounded_profile`, has only the small
    steps of its sampling.)"""
    p = np.asarray(profile, dtype=float).reshape(-1, 2)
    if p.shape[0] < 2:
        return pd.DataFrame({"time_s": [], "jump_m_s2": []})
    slope = np.diff(p[:, 1]) / np.diff(p[:, 0])
    jumps = np.diff(np.concatenate([[0.0], slope, [0.0]]))
    out = pd.DataFrame({"time_s": p[:, 0], "jump_m_s2": jumps})
    out = out[np.abs(out.jump_m_s2) > 1e-12]
    return out.reindex(out.jump_m_s2.abs().sort_values(ascending=False).index).reset_index(
        drop=True)


def base_run_diagnostics(ds: xr.Dataset, scenario: Scenario | None = None,
                         window: tuple[float, float] | None = None,
                         reference_travel: float = 0.083,
                         f_min: float | None = None) -> dict:
    """The numbers that show whether, and why, a speed-controlled run rings.

    Parameters
    ----------
    ds : xarray.Dataset
        A result of :func:`ltdsim.simulate` in speed mode.
    scenario : Scenario, optional
        The scenario of ``ds`` (default: the one stored in it).
    window : (float, float), optional
        Cruise window, s; default :func:`cruise_window`.
    reference_travel : float
        Travel, m, for gears without a stated one (see
        :func:`ltdsim.results.summary.gear_travel_check`).
    f_min : float, optional
        Lowest frequency, Hz, taken for the swing's dominant oscillation (default: two
        cycles in the window); e.g. half the train's lowest mode, so that the slow
        change of force over a grade or a curve does not count as a swing.

    Returns
    -------
    dict
        ``window_s`` (s, s); ``traction_swing_N`` (half the peak-to-peak of the
        locomotive force over the window, N), ``traction_swing_rms_N`` (N),
        ``traction_period_s`` (s, its dominant period) and ``traction_mean_N`` (N);
        ``coupler1_swing_N`` (N) and ``coupler1_period_s`` (s) of the first coupler;
        ``speed_error_rms_m_s`` (whole run) and ``speed_error_rms_window_m_s`` (m/s);
        ``max_gear_deflection_m`` (array per coupler, m beyond the slack, either
        direction), ``max_draft_m``, ``max_buff_m`` (arrays, m), ``travel_m`` (array, m,
        checked against) and ``couplers_beyond_travel`` (list, counted from 1);
        ``max_wagon_acceleration_m_s2`` (largest |acceleration| of an unpowered vehicle,
        m/s^2) and ``max_wagon_acceleration_vehicle`` (counted from 1, 1 = lead);
        ``reference_corner_m_s2`` (largest jump of the reference's acceleration, m/s^2,
        after rounding) and ``reference_corner_time_s`` (s); ``held_mode_hz`` (lowest
        natural frequency of the wagons against a locomotive held still, at the draft
        stiffness, Hz).
    """
    from ltdsim.engine.lowering import rounded_profile
    from ltdsim.analysis.modal import chain_modes
    from ltdsim.results.summary import gear_travel_check

    sc = scenario_of(ds, scenario)
    a, b = cruise_window(ds) if window is None else window
    sel = ds.sel(time=slice(a, b))
    t = sel.time.values
    trac = oscillation(t, sel.traction_force.values, f_min)
    c1 = oscillation(t, sel.coupler_force.values[:, 0], f_min)
    err = ds.speed_error.values
    gears = gear_travel_check(ds, sc, reference_travel)
    powered = np.array([v.powered for v in sc.vehicles])
    acc = np.abs(ds.acceleration.values[:, ~powered])
    wagons = np.flatnonzero(~powered)
    corners = reference_corners(np.column_stack(rounded_profile(sc.driver.speed_profile)))
    k = np.array([_stiffness(sc.coupler(j), "draft") for j in range(sc.n_couplers)])
    lead = sc.consists()[0].vehicles[0]
    held = np.nan
    if lead == 0:
        f_held, _ = chain_modes([v.mass for v in sc.vehicles], k, lead="held")
        held = float(f_held[0])
    peak = np.unravel_index(np.argmax(acc), acc.shape) if acc.size else (0, 0)
    return {
        "window_s": (float(a), float(b)),
        "traction_swing_N": trac["amplitude"],
        "traction_swing_rms_N": trac["rms"],
        "traction_period_s": trac["period_s"],
        "traction_mean_N": trac["mean"],
        "coupler1_swing_N": c1["amplitude"],
        "coupler1_period_s": c1["period_s"],
        "speed_error_rms_m_s": float(np.sqrt(np.nanmean(err * err))),
        "speed_error_rms_window_m_s": float(np.sqrt(np.nanmean(sel.speed_error.values ** 2))),
        "max_gear_deflection_m": gears.max_deflection_m.values,
        "max_draft_m": gears.max_draft_m.values,
        "max_buff_m": gears.max_buff_m.values,
        "travel_m": gears.travel_m.values,
        "couplers_beyond_travel": [int(j) + 1 for j in gears.index[gears.exceeds]],
        "max_wagon_acceleration_m_s2": float(acc.max()) if acc.size else 0.0,
        "max_wagon_acceleration_vehicle": int(wagons[peak[1]]) + 1 if acc.size else 0,
        "reference_corner_m_s2": float(abs(corners.jump_m_s2.iloc[0])) if len(corners) else 0.0,
        "reference_corner_time_s": float(corners.time_s.iloc[0]) if len(corners) else np.nan,
        "held_mode_hz": held,
    }


def _stiffness(c, which: str) -> float:
    """Linearised stiffness of a coupling, N/m: in draft at rest ("draft": a simplified
    coupler's k2 + k3, the nonlinear term unfaded) or in buff ("buff": k1); a linear
    coupler's stiffness either way; its gears in series (the registry's,
    ltdsim.engine.couplers.linearised_stiffness, as the kernel simulates it)."""
    from ltdsim.engine.couplers import linearised_stiffness

    k = linearised_stiffness(c, which)
    if k is None:
        raise ValueError(f"no {which} stiffness for a {c.model!r} coupler: linearise it by "
                         "hand")
    return float(k)


def closed_loop_modes(scenario: Scenario, stiffness: str | float = "draft",
                      demand_mass: float | None = None) -> pd.DataFrame:
    """Modes of the train linearised about steady running, with the speed controller
    closed around it (python-control).

    The couplers are springs (``stiffness``: "draft" = k2 + k3 or a linear coupler's
    stiffness, "buff" = k1, or a number in N/m) with their dampers, without slack; Davis
    ``b`` acts on every vehicle. The controller is the scenario's PID in continuous
    form ``kp + ki/s + kd N s/(s + N)`` (its sample time, 1e-4 s in the study, is far
    faster than any mode), its output times ``demand_mass`` (kg; default as the
    scenario's ``driver.pid.acceleration_of`` says: the train's total mass or the lead
    locomotive's) is the locomotive force, and it reads the speed of
    the lead powered vehicle. Traction limits and the resistance feed-forward (a
    function of speed, not of the error) are left out.

    Returns
    -------
    pandas.DataFrame
        One row per oscillatory closed-loop mode, lowest first: ``frequency_hz`` (Hz,
        undamped natural frequency), ``damping_ratio`` (-), ``decay_time_s`` (s, time
        for the amplitude to fall by e).
    """
    import control as ct

    from ltdsim.analysis.modal import chain_stiffness

    if scenario.driver.mode != "speed":
        raise ValueError("closed_loop_modes needs a scenario in speed mode")
    m = np.array([v.mass for v in scenario.vehicles])
    n = m.size
    nc = n - 1
    params = [scenario.coupler(j) for j in range(nc)]
    if isinstance(stiffness, str):
        if stiffness in ("draft", "buff"):
            k = [_stiffness(c, stiffness) for c in params]
        else:
            raise ValueError(f"stiffness must be 'draft', 'buff' or N/m, got {stiffness!r}")
    else:
        k = [float(stiffness)] * nc
    K = chain_stiffness(k) if nc else np.zeros((1, 1))
    C = (chain_stiffness([c.damping for c in params]) if nc else np.zeros((1, 1))) \
        + np.diag([v.davis.b for v in scenario.vehicles])
    mi = np.diag(1.0 / m)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-mi @ K, -mi @ C]])
    lead = scenario.consists()[0].vehicles[0]
    B = np.zeros((2 * n, 1))
    B[n + lead, 0] = 1.0 / m[lead]
    Cm = np.zeros((1, 2 * n))
    Cm[0, n + lead] = 1.0
    plant = ct.ss(A, B, Cm, 0.0)
    pid = scenario.driver.pid
    s = ct.tf("s")
    ctrl = pid.kp + pid.ki / s + pid.kd * pid.n * s / (s + pid.n)
    if demand_mass is not None:
        mass = float(demand_mass)
    elif pid.acceleration_of == "locomotive":
        mass = float(m[scenario.consists()[0].vehicles].sum())
    else:
        mass = float(m.sum())
    poles = ct.feedback(mass * ctrl * plant, 1).poles()
    osc = poles[poles.imag > 1e-9]
    wn = np.abs(osc)
    zeta = -osc.real / wn
    order = np.argsort(wn)
    decay = np.where(osc.real < 0.0, -1.0 / np.where(osc.real < 0.0, osc.real, -1.0), np.inf)
    return pd.DataFrame({"frequency_hz": wn[order] / (2 * np.pi),
                         "damping_ratio": zeta[order],
                         "decay_time_s": decay[order]})


