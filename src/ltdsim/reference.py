"""The same train model as a plain NumPy right-hand side for ``scipy.integrate.solve_ivp``.

It is written independently of the compiled kernel (vectorised over vehicles, no
search cursors, no work arrays) and serves two purposes: tests check the kernel's
integrators against ``solve_ivp`` on it, and the benchmark times it as the
"plain SciPy" reference.

The discrete PID cannot live inside an adaptive solver, so in speed mode this model
uses the continuous-time PID with the same gains: ``u = kp e + ki I + N (kd e - F)``,
``dI/dt = e``, ``dF/dt = N (kd e - F)``. With the study's Ts = 1e-4 s the two agree to
first order in Ts.
"""

from __future__ import annotations

import numpy as np

from ltdsim.lowering import (
    C_LINEAR, C_SIMPLIFIED, D_KD, D_KI, D_KP, D_MODE, D_N, K_TAU, MODE_NOTCH, MODE_SPEED, P_D0,
    P_DAMP, P_IVC, P_K1, P_K2, P_K3, P_KSOLID, P_PRELOAD, P_SLACK, P_STIFF, P_TRAVEL, T_AMAX,
    T_DMAX, T_FF, T_FMAX, T_G, T_MADH, T_MTOT, T_PMAX, T_REF, V_DA, V_DB, V_DC, V_DIV0, V_MASS,
    V_P0, V_SHARE, V_WMASS, lower,
)
from ltdsim.physics import (
    coupler_linear, coupler_simplified, curve_resistance, davis_resistance, grade_resistance,
    traction_limit,
)
from ltdsim.scenario import Scenario


def make_rhs(scenario: Scenario):
    """Return ``(f, y0)``: ``f(t, y)`` for ``solve_ivp`` and the initial state.

    The state is ``[x (n), v (n)]`` (displacements m, speeds m/s) plus, in speed mode,
    the PID integrator and filter states.
    """
    low = lower(scenario)
    unsupported = [what for what, present in (
        ("hysteretic draft gears", (low.cpl_model > C_SIMPLIFIED).any()),
        ("air brakes", low.braked),
        ("several locomotive consists", low.cons.shape[0] > 1),
        ("traction lag", (low.cons[:, K_TAU] > 0).any()),
        ("notch mode", low.drv[D_MODE] == MODE_NOTCH)) if present]
    if unsupported:
        raise NotImplementedError("the NumPy reference model covers linear and simplified "
                                  "couplers with one consist only; not: " + ", ".join(unsupported))
    n = low.n
    veh, cpl, trac, drv = low.veh, low.cpl, low.trac, low.drv
    linear = low.cpl_model == C_LINEAR
    g = trac[T_G]
    ref = int(trac[T_REF])
    speed = drv[D_MODE] == MODE_SPEED
    m = veh[:, V_MASS]
    wm = veh[:, V_WMASS]

    def f(t, y):
        x, v = y[:n], y[n:2 * n]
        p = veh[:, V_P0] + x
        k = np.clip(np.searchsorted(low.track_pos, p, side="right") - 1, 0, None)
        res = (davis_resistance(v, veh[:, V_DA], veh[:, V_DB], veh[:, V_DC], 1.0 / veh[:, V_DIV0])
               + grade_resistance(wm, low.track_grade[k], g)
               + curve_resistance(v, wm, low.track_curv[k], low.curve_h, g))
        d = x[:-1] - x[1:] + cpl[:, P_D0]
        dd = v[:-1] - v[1:]
        tension = np.where(
            linear,
            coupler_linear(d, dd, cpl[:, P_SLACK], cpl[:, P_STIFF], cpl[:, P_DAMP],
                           cpl[:, P_TRAVEL], cpl[:, P_KSOLID]),
            coupler_simplified(d, dd, cpl[:, P_SLACK], cpl[:, P_PRELOAD], cpl[:, P_DAMP],
                               cpl[:, P_K1], cpl[:, P_K2], cpl[:, P_K3], 1.0 / cpl[:, P_IVC],
                               cpl[:, P_TRAVEL], cpl[:, P_KSOLID]))
        extra = []
        if speed:
            e = np.interp(t, low.prof_t, low.prof_y) - v[ref]
            u_d = drv[D_N] * (drv[D_KD] * e - y[2 * n + 1])
            u = drv[D_KP] * e + drv[D_KI] * y[2 * n] + u_d
            a_dem = min(max(u, -trac[T_DMAX]), trac[T_AMAX])
            demand = a_dem * trac[T_MTOT] + trac[T_FF] * res.sum()
            extra = [e, u_d]
        else:
            demand = np.interp(t, low.prof_t, low.prof_y)
        lim = traction_limit(v[ref], trac[T_FMAX], trac[T_PMAX], trac[T_MADH], g)
        force = veh[:, V_SHARE] * min(max(demand, -lim), lim) - res
        force[:-1] -= tension
        force[1:] += tension
        return np.concatenate([v, force / m, extra])

    y0 = low.y0.copy()
    if speed:
        y0 = np.concatenate([y0, [0.0, 0.0]])
    return f, y0
