"""The single-vehicle brake stand (``ltdsim brake-test`` and the valve tests): one
driver's valve feeding one volume (a vehicle's brake pipe, 15 m of 1 1/4 in. pipe,
isothermal at the valves' 20 C, as on a test stand whose pipe the valves' timing is read
from) that one control valve draws from; integrated by classical Runge-Kutta at a fixed
step (1 ms by default, which keeps linear invariants such as the air mass to rounding).

States (:data:`N_Y`): the pipe's pressure (Pa abs), the control valve's and the driver's
valve's states (:data:`~ltdsim.physics.air.brakevalves.CV_STATES`, ``DV_STATES``), the
air exhausted and the air fed by a compressor (kg). Commands are rows of (time s,
handle code ``H_*``, service reduction Pa, forced vent Cd x area m^2)."""

import math

import numpy as np
from numba import njit

from ltdsim.data import load_preset
from ltdsim.physics.air import brakevalves as bv
from ltdsim.physics.air.pneumatics import orifice_flow

GAMMA, R_GAS, T, ATM, R_LIN = 1.4, 287.05, 293.15, 101325.0, 0.995
PIPE_VOLUME = math.pi / 4 * 0.0318**2 * 15.0  # m^3: 15 m of 1 1/4 in pipe
NC, ND = bv.N_CV, bv.N_DV
I_PIPE, I_CV, I_DV = 0, 1, 1 + bv.N_CV
I_EXH = 1 + bv.N_CV + bv.N_DV
I_FED = I_EXH + 1
N_Y = I_FED + 1


@njit(cache=True)
def rig_rhs(y, cv, dv, handle, reduction, forced, pipe_volume, dy):
    """Rates of the rig's states. ``forced`` >= 0 replaces the driver's valve by a pipe
    vent of that Cd x area (m^2) (the driver's valve then sits in lap)."""
    p = y[I_PIPE]
    draw, exh_cv, _ = bv.control_valve(p, T, y[I_CV:I_CV + NC], cv, GAMMA, R_GAS, T, ATM,
                                       R_LIN, dy[I_CV:I_CV + NC])
    into, exh_dv, _ = bv.driver_valve(p, T, y[I_DV:I_DV + ND], dv, handle, reduction, GAMMA,
                                      R_GAS, T, ATM, R_LIN, dy[I_DV:I_DV + ND])
    comp = bv.driver_valve_compressor(y[I_DV:I_DV + ND], dv)
    extra = 0.0
    if forced > 0.0:
        extra = orifice_flow(p, ATM, forced, GAMMA, R_GAS, T, R_LIN)
    dy[I_PIPE] = R_GAS * T / pipe_volume * (into - draw - extra)
    dy[I_EXH] = exh_cv + exh_dv + extra
    dy[I_FED] = comp


@njit(cache=True)
def rig_run(y0, cv, dv, t_end, h, times, handles, reductions, vents, pipe_volume, every):
    """Integrate from 0 to ``t_end`` with step ``h``; the command in force at time t is
    the last row i with times[i] <= t (handle, reduction Pa, forced vent Cd A m^2).
    Returns (t, y) sampled every ``every`` steps."""
    n = round(t_end / h)
    m = n // every + 1
    ts = np.empty(m)
    ys = np.empty((m, y0.size))
    y = y0.copy()
    k1 = np.empty_like(y)
    k2 = np.empty_like(y)
    k3 = np.empty_like(y)
    k4 = np.empty_like(y)
    tmp = np.empty_like(y)
    j = 0
    ts[0] = 0.0
    ys[0] = y
    row = 0
    for i in range(n):
        t = i * h
        while row + 1 < times.size and times[row + 1] <= t + 1e-12:
            row += 1
        hd, red, ven = handles[row], reductions[row], vents[row]
        rig_rhs(y, cv, dv, hd, red, ven, pipe_volume, k1)
        for q in range(y.size):
            tmp[q] = y[q] + 0.5 * h * k1[q]
        rig_rhs(tmp, cv, dv, hd, red, ven, pipe_volume, k2)
        for q in range(y.size):
            tmp[q] = y[q] + 0.5 * h * k2[q]
        rig_rhs(tmp, cv, dv, hd, red, ven, pipe_volume, k3)
        for q in range(y.size):
            tmp[q] = y[q] + h * k3[q]
        rig_rhs(tmp, cv, dv, hd, red, ven, pipe_volume, k4)
        for q in range(y.size):
            y[q] += h / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q])
        if (i + 1) % every == 0:
            j += 1
            ts[j] = (i + 1) * h
            ys[j] = y
    return ts[:j + 1], ys[:j + 1]


def rows(name):
    """The parameter rows (control valve, driver's valve) of the valve preset ``name``."""
    preset = load_preset("brakes", name)
    return bv.control_valve_row(preset["control_valve"]), bv.driver_valve_row(
        preset["driver_valve"])


def charged(cv, dv, pipe_volume=PIPE_VOLUME):
    """Initial state of the rig charged to the driver's valve's regulated pressure."""
    p0 = ATM + dv[bv.DV_PARAMS.index("regulated")]
    y = np.zeros(N_Y)
    y[I_PIPE] = p0
    y[I_CV:I_CV + NC] = bv.control_valve_init(p0, cv, ATM)
    y[I_DV:I_DV + ND] = bv.driver_valve_init(p0, dv, ATM)
    return y


def run(name_or_rows, commands, t_end, h=1e-3, every=10, y0=None,
        pipe_volume=PIPE_VOLUME):
    """commands: list of (time s, handle name or code, reduction Pa, forced vent m^2)."""
    cv, dv = rows(name_or_rows) if isinstance(name_or_rows, str) else name_or_rows
    times = np.array([c[0] for c in commands], float)
    hnd = np.array([c[1] for c in commands], np.int64)
    red = np.array([c[2] for c in commands], float)
    ven = np.array([c[3] if len(c) > 3 else 0.0 for c in commands], float)
    y = charged(cv, dv, pipe_volume) if y0 is None else y0
    return rig_run(y, cv, dv, t_end, h, times, hnd, red, ven, pipe_volume, every)


def mass(ys, cv, dv, pipe_volume=PIPE_VOLUME):
    """Air in the rig's volumes + exhausted - fed, kg (constant)."""
    out = np.empty(len(ys))
    for i, y in enumerate(ys):
        out[i] = (y[I_PIPE] * pipe_volume / (R_GAS * T)
                  + bv.control_valve_mass(y[I_CV:I_CV + NC], cv, R_GAS, T)
                  + bv.driver_valve_mass(y[I_DV:I_DV + ND], dv, R_GAS, T)
                  + y[I_EXH] - y[I_FED])
    return out


@njit(cache=True)
def _cv_rhs(p, s, cv, ds):
    """The control valve's rates on the pipe pressure p (one compiled copy of the law)."""
    bv.control_valve(p, T, s, cv, GAMMA, R_GAS, T, ATM, R_LIN, ds)


@njit(cache=True)
def cv_run_pipe(s0, cv, t_end, h, p0, rate, total, every):
    """One control valve on a prescribed pipe pressure p0 - min(rate t, total) (Pa abs;
    rate Pa/s, negative for a rise), classical RK4 at step h. Returns (t, states)."""
    n = round(t_end / h)
    m = n // every + 1
    ts = np.empty(m)
    ss = np.empty((m, s0.size))
    s = s0.copy()
    k1 = np.empty_like(s)
    k2 = np.empty_like(s)
    k3 = np.empty_like(s)
    k4 = np.empty_like(s)
    tmp = np.empty_like(s)
    ts[0] = 0.0
    ss[0] = s
    j = 0
    for i in range(n):
        t = i * h
        pa = p0 - min(rate * t, total) if rate > 0 else p0 + min(-rate * t, total)
        pm = p0 - min(rate * (t + 0.5 * h), total) if rate > 0 else p0 + min(-rate * (t + 0.5 * h), total)
        pb = p0 - min(rate * (t + h), total) if rate > 0 else p0 + min(-rate * (t + h), total)
        _cv_rhs(pa, s, cv, k1)
        for q in range(s.size):
            tmp[q] = s[q] + 0.5 * h * k1[q]
        _cv_rhs(pm, tmp, cv, k2)
        for q in range(s.size):
            tmp[q] = s[q] + 0.5 * h * k2[q]
        _cv_rhs(pm, tmp, cv, k3)
        for q in range(s.size):
            tmp[q] = s[q] + h * k3[q]
        _cv_rhs(pb, tmp, cv, k4)
        for q in range(s.size):
            s[q] += h / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q])
        if (i + 1) % every == 0:
            j += 1
            ts[j] = (i + 1) * h
            ss[j] = s
    return ts[:j + 1], ss[:j + 1]
