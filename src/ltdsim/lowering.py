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
C_LINEAR, C_SIMPLIFIED, C_WEDGE, C_TABLE = 0, 1, 2, 3
MODEL_CODES = {"linear": C_LINEAR, "simplified": C_SIMPLIFIED, "friction_wedge": C_WEDGE,
               "table": C_TABLE}
(P_SLACK, P_PRELOAD, P_DAMP, P_STIFF, P_K1, P_K2, P_K3, P_VC, P_D0,
 # hysteretic gears (friction_wedge, table): internal-state offset, rates, limits
 P_ZOFF, P_RATE, P_KLOCK, P_TRAVEL, P_KSOLID,
 # friction_wedge: geometry (tan a, tan b, tan g, G, speed ratios), friction, springs
 P_TA, P_TB, P_TG, P_G, P_C1, P_C2, P_C3, P_H1, P_H2, P_H3, P_S, P_STAB, P_SNV, P_SNX,
 P_KM, P_XM0, P_KR, P_XR0, P_GAP, P_BACK,
 # table: offsets and lengths of the loading and unloading curves in the table store
 P_TLOAD, P_NLOAD, P_TUNL, P_NUNL,
 # hysteretic gears: force of the released gear at zero deflection, N
 P_F0) = range(39)
N_CCOL = 39
#: internal states per hysteretic gear: internal force, plate displacement, impact speed
N_GEAR_STATES = 3
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
    ctab: np.ndarray  # flat store of gear tables (S tables, force-deflection curves)
    tableau: Tableau
    dt: float
    n_steps: int
    record_every: int
    y0: np.ndarray  # initial state [x (n), v (n), gear states (nz)]

    @property
    def n(self) -> int:
        return self.veh.shape[0]

    @property
    def nz(self) -> int:
        """Number of internal gear states."""
        return self.y0.shape[0] - 2 * self.n


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
    tables: list[float] = [0.0]
    nz = 0
    for i in range(nc):
        c = s.coupler(i)
        cpl_model[i] = MODEL_CODES[c.model]
        row = cpl[i]
        row[[P_SLACK, P_PRELOAD, P_DAMP, P_STIFF, P_K1, P_K2, P_K3, P_VC, P_D0]] = [
            c.slack, c.preload, c.damping, c.stiffness or 0.0, c.k1 or 0.0, c.k2, c.k3 or 0.0,
            c.v_c or 1.0, sign0 * 0.5 * c.slack]
        row[P_ZOFF] = -1.0
        if c.model in ("friction_wedge", "table"):
            row[P_ZOFF] = nz
            nz += N_GEAR_STATES
            row[P_RATE] = 1.0 / (c.tracking_time or 4.0 * s.solver.dt)
            row[P_KLOCK] = c.k_locked
            row[P_KSOLID] = c.solid_stiffness
            row[P_F0] = released_force(c)
        if c.model == "friction_wedge":
            _lower_wedge(c, row, tables)
        elif c.model == "table":
            _lower_table(c, row, tables)

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

    y0 = np.zeros(2 * n + nz)
    y0[n:2 * n] = s.initial.speed if s.initial.velocities is None else s.initial.velocities
    for i in range(nc):  # gears start released: internal force on the loading curve at 0
        if cpl[i, P_ZOFF] >= 0:
            y0[2 * n + int(cpl[i, P_ZOFF])] = cpl[i, P_F0]
    return Lowered(
        veh=veh, cpl_model=cpl_model, cpl=cpl,
        track_pos=track_pos, track_grade=track_grade, track_curv=track_curv,
        curve_h=float(s.track.curve_h), trac=trac, drv=drv,
        prof_t=np.ascontiguousarray(prof[:, 0]), prof_y=np.ascontiguousarray(prof[:, 1]),
        ctab=np.array(tables, dtype=float),
        tableau=get_tableau(s.solver.method), dt=float(s.solver.dt),
        n_steps=s.solver.n_steps, record_every=s.solver.record_every, y0=y0,
    )


def _append(tables: list[float], values) -> int:
    """Append values to the flat table store and return their offset."""
    off = len(tables)
    tables.extend(float(v) for v in values)
    return off


def _lower_wedge(c, row, tables) -> None:
    from ltdsim.physics.draftgear import wedge_geometry

    a, b, g = (np.radians(v) for v in (c.alpha_deg, c.beta_deg, c.gamma_deg))
    row[[P_TA, P_TB, P_TG, P_G, P_C1, P_C2, P_C3]] = wedge_geometry(a, b, g)
    row[[P_H1, P_H2, P_H3]] = c.h1, c.h2, c.h3
    row[[P_KM, P_XM0, P_KR, P_XR0, P_GAP, P_BACK]] = (c.k_m, c.x_m0, c.k_r, c.x_r0,
                                                      c.plate_gap, c.plate_backlash)
    row[P_TRAVEL] = c.travel
    row[P_STAB] = -1.0
    if c.S_table is not None:
        t = c.S_table
        row[P_STAB] = _append(tables, [*t.velocity, *t.deflection,
                                       *np.asarray(t.values, dtype=float).ravel()])
        row[P_SNV], row[P_SNX] = len(t.velocity), len(t.deflection)
    else:
        row[P_S] = c.S


def _lower_table(c, row, tables) -> None:
    for pts, off_col, n_col in ((c.loading, P_TLOAD, P_NLOAD), (c.unloading, P_TUNL, P_NUNL)):
        arr = np.asarray(pts, dtype=float)
        row[off_col] = _append(tables, [*arr[:, 0], *arr[:, 1]])
        row[n_col] = len(arr)
    last = max(c.loading[-1][0], c.unloading[-1][0])
    row[P_TRAVEL] = c.travel if c.travel is not None else last


def released_force(c) -> float:
    """Force of a released hysteretic gear at zero deflection on its loading curve, N
    (the initial value of its internal force)."""
    if c.model == "table":
        return float(c.loading[0][1])
    from ltdsim.physics.draftgear import wedge_gear_quasistatic

    return float(wedge_gear_quasistatic(
        0.0, 1.0, *np.radians([c.alpha_deg, c.beta_deg, c.gamma_deg]), c.h1, c.h2, c.h3,
        c.S if c.S is not None else c.S_table.values[0][0], c.k_m, c.x_m0, c.k_r, c.x_r0,
        c.plate_gap, c.plate_backlash, 0.0))


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
