"""Lower a validated :class:`~ltdsim.scenario.Scenario` to the flat arrays the kernel reads.

This is the only place that knows both the scenario's structure and the kernel's
array layout; the column constants below are shared with :mod:`ltdsim.kernel`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ltdsim.integrators import Tableau, get_tableau
from ltdsim.physics.control import METHODS
from ltdsim.scenario import Scenario

# vehicle table columns
V_MASS, V_WMASS, V_DA, V_DB, V_DC, V_DV0, V_SHARE, V_P0 = range(8)
N_VCOL = 8
# coupler models and parameter columns
C_LINEAR, C_SIMPLIFIED = 0, 1
MODEL_CODES = {"linear": C_LINEAR, "simplified": C_SIMPLIFIED}
P_SLACK, P_PRELOAD, P_DAMP, P_STIFF, P_K1, P_K2, P_K3, P_VC, P_D0 = range(9)
N_CCOL = 9
# traction parameter vector
T_FMAX, T_PMAX, T_MADH, T_AMAX, T_DMAX, T_FF, T_MTOT, T_G, T_REF = range(9)
# driver parameter vector
D_MODE, D_KP, D_KI, D_KD, D_N, D_TS, D_INT, D_FILT, D_EVERY = range(9)
MODE_SPEED, MODE_FORCE = 0, 1


@dataclass(frozen=True)
class Lowered:
    """A scenario as flat numeric arrays (all SI)."""

    veh: np.ndarray  # (n, N_VCOL)
    cpl_model: np.ndarray  # (n-1,) int64
    cpl: np.ndarray  # (n-1, N_CCOL)
    track_pos: np.ndarray  # start of each track segment, m (grade and curve breakpoints merged)
    track_grade: np.ndarray  # rise/run on each segment
    track_curv: np.ndarray  # curvature 1/R on each segment, 1/m
    curve_h: float
    trac: np.ndarray
    drv: np.ndarray
    prof_t: np.ndarray
    prof_y: np.ndarray
    tableau: Tableau
    dt: float
    n_steps: int
    record_every: int
    y0: np.ndarray  # initial state [x (n), v (n)]

    @property
    def n(self) -> int:
        return self.veh.shape[0]


def lower(s: Scenario) -> Lowered:
    """Turn a scenario into kernel arrays."""
    n = s.n_vehicles
    veh = np.zeros((n, N_VCOL))
    powered = np.array([v.powered for v in s.vehicles], dtype=bool)
    # vehicle centres: lead at 0, the rest behind it at half-length spacings
    lengths = np.array([v.length for v in s.vehicles])
    p0 = np.zeros(n)
    if n > 1:
        p0[1:] = -np.cumsum(0.5 * (lengths[:-1] + lengths[1:]))
    for i, v in enumerate(s.vehicles):
        veh[i, V_MASS] = v.mass
        veh[i, V_WMASS] = v.weight_mass
        veh[i, V_DA], veh[i, V_DB], veh[i, V_DC] = v.davis.a, v.davis.b, v.davis.c
        veh[i, V_DV0] = v.davis.v0
    veh[:, V_SHARE] = powered / powered.sum()
    veh[:, V_P0] = p0

    nc = n - 1
    cpl_model = np.zeros(nc, dtype=np.int64)
    cpl = np.zeros((nc, N_CCOL))
    sign0 = {"neutral": 0.0, "stretched": 1.0, "bunched": -1.0}[s.initial.couplers]
    for i in range(nc):
        c = s.coupler(i)
        cpl_model[i] = MODEL_CODES[c.model]
        cpl[i] = [c.slack, c.preload, c.damping, c.stiffness or 0.0, c.k1 or 0.0, c.k2,
                  c.k3 or 0.0, c.v_c or 1.0, sign0 * 0.5 * c.slack]

    track_pos, track_grade, track_curv = merge_track(s.track.gradient, s.track.curve)

    t = s.traction
    ref = int(np.argmax(powered))  # the lead powered vehicle measures speed
    trac = np.array([t.max_force, t.max_power, t.adhesion_mass, t.max_accel, t.max_decel,
                     1.0 if t.feedforward else 0.0, veh[:, V_MASS].sum(), s.track.gravity,
                     float(ref)])

    d = s.driver
    drv = np.zeros(9)
    if d.mode == "speed":
        pid = d.pid
        every = pid.ts / s.solver.dt  # whole multiple, checked on load
        drv[:] = [MODE_SPEED, pid.kp, pid.ki, pid.kd, pid.n, pid.ts, METHODS[pid.integrator],
                  METHODS[pid.filter], round(every)]
        prof = np.array(d.speed_profile, dtype=float).reshape(-1, 2)
    else:
        drv[D_MODE] = MODE_FORCE
        drv[D_EVERY] = 1
        prof = np.array(d.force_profile, dtype=float).reshape(-1, 2)

    y0 = np.zeros(2 * n)
    y0[n:] = s.initial.speed
    return Lowered(
        veh=veh, cpl_model=cpl_model, cpl=cpl,
        track_pos=track_pos, track_grade=track_grade, track_curv=track_curv,
        curve_h=float(s.track.curve_h), trac=trac, drv=drv,
        prof_t=np.ascontiguousarray(prof[:, 0]), prof_y=np.ascontiguousarray(prof[:, 1]),
        tableau=get_tableau(s.solver.method), dt=float(s.solver.dt),
        n_steps=s.solver.n_steps, record_every=s.solver.record_every, y0=y0,
    )


def merge_track(gradient, curve) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge the piecewise-constant grade and curve tables onto one set of breakpoints.

    Parameters
    ----------
    gradient : sequence of (start m, rise/run)
    curve : sequence of (start m, radius m), radius 0 for straight track

    Returns
    -------
    pos, grade, curvature : ndarray
        Segment starts (m), grade (rise/run) and curvature (1/m) on each segment; the
        first segment also covers everything before its start.
    """
    gp = np.array(gradient, dtype=float).reshape(-1, 2)
    cp = np.array(curve, dtype=float).reshape(-1, 2)
    pos = np.union1d(gp[:, 0], cp[:, 0])
    gi = np.clip(np.searchsorted(gp[:, 0], pos, side="right") - 1, 0, None)
    ci = np.clip(np.searchsorted(cp[:, 0], pos, side="right") - 1, 0, None)
    radius = cp[ci, 1]
    curv = np.divide(1.0, radius, out=np.zeros_like(radius), where=radius != 0.0)
    return pos, gp[gi, 1].copy(), curv
