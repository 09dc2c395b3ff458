"""Lower a validated :class:`~ltdsim.scenario.Scenario` to the flat arrays the kernel reads.

This is the only place that knows both the scenario's structure and the kernel's
array layout (:mod:`ltdsim.engine.layout` for the vehicle, consist, traction and driver tables,
:mod:`ltdsim.engine.couplers` for the coupler table). Modules outside the engine read a
:class:`Lowered` through its properties, never through column constants.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ltdsim.engine.couplers import HYS_KEDGE, N_CCOL, P_D0, P_F0, P_SLACK, lower_coupler
from ltdsim.engine.integrators import BS23, Tableau, get_tableau
from ltdsim.engine.layout import (
    A_AREA, A_ATM, A_COND, A_DIAM, A_GAMMA, A_RGAS, A_RLIN, A_ROUGH, A_TEMP, A_THERMAL,
    A_VISC, BRAKE_FLUID,
    CMD_EMERGENCY, CMD_FAST_FILL, CMD_LAP, CMD_LEVEL, CMD_RELEASE, CMD_SERVICE, D_AW, D_BCTRL,
    D_BFULLSUM, D_BMODEL,
    D_BPLEN, D_BPOFF, D_BSHOEREF, D_BSLEN, D_BSOFF, D_BSTEP, D_BTAUA, D_BTAUR, D_BVS,
    D_FILT, D_MODE, I_CELLS, I_CV, I_DV, I_EXH, I_NCP, I_PIPE, K_DBFADE, K_FMAX, K_MADH,
    K_NLEN, K_NOFF, K_PMAX, K_RATE, K_SHARE, K_TAU, K_VEH, K_Z, MODE_FORCE, MODE_NOTCH,
    MODE_SPEED, N_AIR, N_AIR_INDEX, N_DRIVE_MISC, N_DRV, N_ENERGY, N_KCOL, N_TRAC, N_VCOL,
    T_AMAX, T_DMAX, T_EZ, T_FF, T_FMAX, T_G, T_MADH, T_MTOT, T_PMAX, T_REF, V_BAREA,
    V_BCELL, V_BCV, V_BDELAY, V_BFRIC, V_BFULL, V_BGAIN, V_BINVSHOES, V_BMU, V_BNTAB,
    V_BPFS, V_BSHOE, V_BSPRING, V_BTAB, V_BZ, V_CONS, V_DA, V_DB, V_DC, V_DIV0, V_MASS,
    V_P0, V_SHARE, V_WMASS, ABSURD_SPEED, append_table,
)
from ltdsim.physics.alignment import reach
from ltdsim.physics.air.brakes import FRICTION_CONSTANT, FRICTION_KARWATZKI, FRICTION_TABLE
from ltdsim.physics.control import METHODS
from ltdsim.physics.drive.traction import braking_share
from ltdsim.physics.resistance import PURE_SIGN
from ltdsim.scenario import Scenario

# the tables' column layouts (V_*, K_*, T_*, D_*) live in ltdsim.engine.layout, the coupler
# table's (P_* common columns, each model's own) with the models in ltdsim.engine.couplers
#: N/m: force states enter the bs23 error norm as force / FORCE_SCALE, so ``atol`` reads
#: as metres of gear deflection for them too (1e-6 m -> 1 N)
FORCE_SCALE = 1.0e6
#: N/m: a hysteretic gear's internal force enters it as force / GEAR_FORCE_SCALE, the
#: slope of a freight draft gear's curves (the friction-wedge presets 9e6-1.7e7 N/m, the
#: polymer gear 4e6 N/m at rest to about 5e7 N/m near its travel), so that ``atol``
#: reads as metres of that gear's deflection, as for the positions (1e-4 m -> 1 kN)
GEAR_FORCE_SCALE = 1.0e7
#: -: the vehicles' speeds enter the bs23 error norm with ``SPEED_SCALE x atol`` (atol 1e-4
#: -> 1 mm/s). Their relative tolerance ``rtol |v|`` governs on the move; the absolute one
#: matters only near standstill, where a tenfold tighter bound cut the steps by a third
#: after the heavy-haul emergency stop without moving a coupler peak
#: (docs/heavy-haul.md, docs/measurements.md)
SPEED_SCALE = 10.0
#: Pa/m: pressure states (fluid brake) enter the bs23 error norm as pressure /
#: PRESSURE_SCALE (atol 1e-6 -> 1 Pa, 1e-4 -> 1 mbar)
PRESSURE_SCALE = 1.0e6
#: kg/(s m): the pipe's face mass flows enter it as flow / FLOW_SCALE (atol 1e-6 ->
#: 1e-5 kg/s); a flow error of 1e-3 kg/s held over a 1 ms step moves a 7.5 m cell of a
#: 32 mm pipe by about 15 Pa
FLOW_SCALE = 10.0
#: kg/(m^3 m): the pipe's cell densities enter it as density / DENSITY_SCALE (atol 1e-6
#: -> 1e-5 kg/m^3, the density of 0.84 Pa of air at 20 C: as the pressures' 1 Pa)
DENSITY_SCALE = 10.0
#: largest number of brake commands (events) one run can issue
MAX_EVENTS = 4096


def hold_force(one) -> float:
    """The force up to which a lowered coupling ``one`` (:func:`lower_coupler`) may be
    held at its slack edge under ``solver.hold_speed``, N: a hysteretic gear's released
    force where the gear has a preload, a slack and a rigid end (no ``edge_stiffness``),
    so that its force steps from none to that preload as the slack closes; else 0 (it
    never is held)."""
    row = one.row
    if one.hysteretic and row[P_F0] > 0.0 and row[HYS_KEDGE] == 0.0 and row[P_SLACK] > 0.0:
        return float(row[P_F0])
    return 0.0


@dataclass(frozen=True)
class Lowered:
    """A scenario as flat numeric arrays (all SI)."""

    veh: np.ndarray  # (n, N_VCOL)
    cons: np.ndarray  # (consists, N_KCOL)
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
    energy_every: int  # fixed step, solver.energy: steps between samples of the body powers
    y0: np.ndarray  # initial state [x (n), v (n), gear states, traction lags, brake cylinders]
    atol: np.ndarray  # bs23 absolute error scale per state element
    rtol: np.ndarray  # bs23 relative tolerance per state element (0 for positions)
    max_step: float
    air_max_step: float  # bs23, fluid brake: largest pneumatic step, s
    adaptive: bool
    energy: bool  # the run accounts for the energy (solver.energy)
    # the fluid brake (brake.model = "fluid"; empty for the lumped brake): gas and pipe
    # constants (layout.AIR_SLOTS), state offsets (layout.AIR_INDEX), cell lengths m,
    # centre distances m, leak Cd x area per cell m^2, cell volumes (the bore's and the
    # side volumes: branch pipes, hoses) m^3, control-valve rows (one per
    # braked vehicle, brakevalves.CV_PARAMS), driver's-valve rows (one per brake-control
    # point, DV_PARAMS) and the cell each driver's valve feeds
    air_gas: np.ndarray = field(default_factory=lambda: np.zeros(N_AIR))
    air_index: np.ndarray = field(default_factory=lambda: np.full(N_AIR_INDEX, -1, np.int64))
    pipe_dx_cell: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pipe_dx_face: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pipe_leak: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pipe_volume: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cv_rows: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    dv_rows: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    dv_cell: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # the induction drives (traction.drive = "induction"; empty rows without any): the
    # drive of each consist (-1: the traction curve), each drive's consist index is
    # implicit in drive_of; its first state in y, its motor (induction.MOTOR_PARAMS),
    # controller (foc.CTRL_PARAMS), wheelset (creep.WHEELSET_PARAMS), rail
    # (creep.CREEP_PARAMS), slip-controller (creep.SLIP_PARAMS) and DM_* rows
    drive_of: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    drive_z: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # the hysteretic gears' internal forces, for the bs23 error norm: the state index of
    # each one's internal force F1 in y, and its coupler (run_adaptive measures the error
    # of the force the gear exerts, kernel.Adaptive)
    gear_f1: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    gear_of: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # its movable plates' state in y (a friction-wedge gear without an S table; -1: none
    # handled there), and whether its states relax in the slack to constant values only
    # (1: run_adaptive may relax them exactly over a step spent in the slack; 0: a wedge
    # gear with an S table, whose impact speed follows the closing speed)
    gear_plate: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    gear_exact: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # bs23 with solver.hold_speed: the speed below which a coupling meeting its slack edge
    # is held there, m/s (0: none is), the force up to which each coupling may be held,
    # N (0: it never is: no preload, a structure at the end of its slack, no slack), and
    # the force tolerance within which a held force may pass that range at a step's end
    # without the step being cut, N
    hold_speed: float = 0.0
    hold_f: np.ndarray = field(default_factory=lambda: np.zeros(0))
    hold_ftol: float = 0.0
    drive_motor: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    drive_ctrl: np.ndarray = field(default_factory=lambda: np.zeros((0, 18)))
    drive_ws: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    drive_rail: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    drive_slip: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    drive_misc: np.ndarray = field(default_factory=lambda: np.zeros((0, N_DRIVE_MISC)))

    @property
    def n(self) -> int:
        return self.veh.shape[0]

    @property
    def fluid(self) -> bool:
        """True for the fluid-dynamic air brake."""
        return bool(self.drv[D_BMODEL] == BRAKE_FLUID)

    @property
    def braked(self) -> bool:
        """True when some vehicle has an air brake."""
        return bool((self.veh[:, V_BZ] >= 0).any())

    @property
    def p0(self) -> np.ndarray:
        """Initial track position of each vehicle's centre, m (lead at 0)."""
        return self.veh[:, V_P0]

    @property
    def d0(self) -> np.ndarray:
        """Initial deflection of each coupler, m: the offset added to ``x_j - x_(j+1)``
        (nonzero when the train starts stretched or bunched)."""
        return self.cpl[:, P_D0]

    @property
    def speed_vehicle(self) -> int:
        """Index of the vehicle whose speed the driver reads (the lead consist's first)."""
        return int(self.trac[T_REF])


def lower(s: Scenario) -> Lowered:
    """Turn a scenario into kernel arrays."""
    n = s.n_vehicles
    veh = np.zeros((n, N_VCOL))
    # vehicle centres: lead at 0, the rest behind it at half-length spacings
    lengths = np.array([v.length for v in s.vehicles])
    p0 = np.zeros(n)
    if n > 1:
        p0[1:] = -np.cumsum(0.5 * (lengths[:-1] + lengths[1:]))
    for i, v in enumerate(s.vehicles):
        veh[i, V_MASS] = v.mass
        veh[i, V_WMASS] = v.weight_mass
        veh[i, V_DA], veh[i, V_DB], veh[i, V_DC] = v.davis.a, v.davis.b, v.davis.c
        veh[i, V_DIV0] = 1.0 / v.davis.v0 if v.davis.v0 > 1e-12 else PURE_SIGN
    veh[:, V_P0] = p0
    veh[:, V_CONS] = 0.0  # unpowered vehicles: consist 0 with share 0
    veh[:, V_BZ] = -1.0
    veh[:, V_BTAB] = -1.0
    tables: list[float] = [0.0]

    nc = n - 1
    cpl_model = np.zeros(nc, dtype=np.int64)
    cpl = np.zeros((nc, N_CCOL))
    sign0 = {"neutral": 0.0, "stretched": 1.0, "bunched": -1.0}[s.initial.couplers]
    y0_extra: list[float] = []
    # what each state is, for the bs23 error weights
    kinds = ["x"] * n + ["speed"] * n
    nz = 0
    gear_f1: list[int] = []
    gear_of: list[int] = []
    gear_plate: list[int] = []
    gear_exact: list[int] = []
    hold_f = np.zeros(nc)
    for i in range(nc):
        one = lower_coupler(s.coupler(i), tables, sign0=sign0, state_offset=nz)
        cpl_model[i] = one.code
        cpl[i] = one.row
        hold_f[i] = hold_force(one)
        if one.hysteretic:  # its internal force F1 comes first
            gear_f1.append(2 * n + nz)
            gear_of.append(i)
            exact = one.states in (("force",), ("force", "x"))  # (no impact speed)
            gear_plate.append(2 * n + nz + 1 if one.states == ("force", "x") else -1)
            gear_exact.append(int(exact))
        nz += len(one.states)
        kinds += one.states
        y0_extra += one.y0
    ny = 2 * n + nz

    # the curve steps over the stretch the train can reach in the run: its centres now,
    # each moving at most ABSURD_SPEED (beyond it the run stops as blown up) for t_end
    stretch = reach(float(veh[:, V_P0].min()), float(veh[:, V_P0].max()),
                    ABSURD_SPEED * s.solver.t_end)
    track_pos, track_grade, track_curv = merge_track(s.track.gradient,
                                                     s.track.resistance_curve(stretch))
    g = s.track.gravity
    m_total = veh[:, V_MASS].sum()

    # locomotive consists
    t = s.traction
    consists = s.consists()
    cons = np.zeros((len(consists), N_KCOL))
    drive_rows: list[dict] = []
    d = s.driver
    for k, loco in enumerate(consists):
        def pick(key, loco=loco):
            own = getattr(loco, key)
            return getattr(t, key) if own is None else own
        row = cons[k]
        row[[K_FMAX, K_PMAX, K_MADH]] = pick("max_force"), pick("max_power"), pick("adhesion_mass")
        row[K_TAU] = pick("time_constant")
        row[K_DBFADE] = t.brake_fade
        row[K_Z] = -1.0
        row[K_VEH] = loco.vehicles[0]
        if (loco.drive or t.drive) == "induction":
            # the induction drive replaces the lag: its states (motor, controller,
            # wheelset, slip limit) among the mechanical ones, before any brake state
            drive_rows.append(_drive_rows(s, loco, k, ny))
            ny += N_DRIVE_STATES
            y0_extra.extend(drive_rows[-1]["y0"])
            kinds.extend(DRIVE_KINDS)
        elif row[K_TAU] > 0.0:
            row[K_Z] = ny
            ny += 1
            y0_extra.append(0.0)
            kinds.append("force")
        for i in loco.vehicles:
            veh[i, V_CONS] = k
            veh[i, V_SHARE] = 1.0 / len(loco.vehicles)
        if loco.notch_profile is not None:  # (never the lead: checked on load)
            prof = np.asarray(loco.notch_profile, dtype=float)
            row[K_NOFF] = append_table(tables, [*prof[:, 0], *prof[:, 1]])
            row[K_NLEN] = len(prof)
    followers = cons[:, K_NLEN] == 0
    cons[followers, K_SHARE] = cons[followers, K_FMAX] / cons[followers, K_FMAX].sum()
    # force rate: jerk limit x train mass, shared like the demand
    for k, loco in enumerate(consists):
        jerk = t.jerk_limit if loco.jerk_limit is None else loco.jerk_limit
        share = cons[k, K_FMAX] / cons[:, K_FMAX].sum()
        cons[k, K_RATE] = jerk * m_total * share

    # under bs23 the energy terms are states (solver.energy), among the mechanical ones,
    # before any brake state; the fixed-step kernel sums them step by step instead
    ez = -1
    if s.solver.energy and s.solver.adaptive:
        ez = ny
        ne = N_ENERGY + nc
        ny += ne
        y0_extra.extend([0.0] * ne)
        kinds.extend(["energy"] * ne)

    ref = int(cons[0, K_VEH])  # the lead consist's first vehicle measures speed
    # the speed controller's output is a demanded acceleration of the train (force =
    # output x train mass) or of the lead locomotive (x its own mass); either way
    # max_accel and max_decel limit the train's acceleration, so the output's clip
    # scales with the ratio of the masses
    m_demand = m_total
    if d.mode == "speed" and d.pid.acceleration_of == "locomotive":
        m_demand = float(veh[consists[0].vehicles, V_MASS].sum())
    ratio = m_total / m_demand  # (exactly 1 for the train)
    trac = np.zeros(N_TRAC)
    trac[T_FMAX], trac[T_PMAX], trac[T_MADH] = cons[0, K_FMAX], cons[0, K_PMAX], cons[0, K_MADH]
    trac[T_AMAX], trac[T_DMAX] = t.max_accel * ratio, t.max_decel * ratio
    trac[T_FF] = 1.0 if t.feedforward else 0.0
    trac[T_MTOT], trac[T_G], trac[T_REF], trac[T_EZ] = m_demand, g, float(ref), float(ez)

    drv = np.zeros(N_DRV)
    if d.mode == "speed":
        pid = d.pid
        drv[:D_FILT + 1] = [MODE_SPEED, pid.kp, pid.ki, pid.kd, pid.n, pid.ts,
                            METHODS[pid.integrator], METHODS[pid.filter]]
        drv[D_AW] = 1.0 if pid.anti_windup else 0.0
        prof = np.column_stack(rounded_profile(d.speed_profile))
    elif d.mode == "force":
        drv[D_MODE] = MODE_FORCE
        prof = np.array(d.force_profile, dtype=float).reshape(-1, 2)
    else:
        drv[D_MODE] = MODE_NOTCH
        prof = np.array(d.notch_profile, dtype=float).reshape(-1, 2)

    # air brakes
    b = s.brake
    fluid = b.model == "fluid"
    control = _brake_control_vehicles(consists)
    control_points = [p0[i] for i in control]
    air = _fluid_rows(s, lengths, control) if fluid else None
    shoe_forces = []
    for i, v in enumerate(s.vehicles):
        if air is not None:
            veh[i, V_BCELL] = air["geometry"].vehicle_cell[i]
        if v.brake is None:
            continue
        vb = v.brake
        veh[i, V_BZ] = ny
        if air is None:
            ny += 1
            y0_extra.append(0.0)
            kinds.append("fill")
            veh[i, V_BFULL] = vb.cylinder_force * vb.rigging_ratio
        else:
            k = len(shoe_forces)
            p_fs = air["full_service"]
            area = vb.piston_area
            if area is None:  # the full service gives cylinder_force (common15.md)
                area = (vb.cylinder_force / vb.efficiency + vb.return_spring) / p_fs
            veh[i, V_BCV] = k
            veh[i, V_BAREA] = area
            veh[i, V_BSPRING] = vb.return_spring
            veh[i, V_BGAIN] = vb.efficiency * vb.rigging_ratio
            veh[i, V_BINVSHOES] = 1.0 / vb.shoes
            veh[i, V_BPFS] = p_fs
            veh[i, V_BFULL] = max(p_fs * area - vb.return_spring, 0.0) * veh[i, V_BGAIN]
            ny += len(air["cv_init"])
            y0_extra.extend(air["cv_init"])
            kinds.extend(air["cv_kinds"])
        veh[i, V_BSHOE] = veh[i, V_BFULL] / vb.shoes
        shoe_forces.append(veh[i, V_BSHOE])
        if vb.friction_table is not None:
            tab = np.asarray(vb.friction_table, dtype=float)
            veh[i, V_BFRIC] = FRICTION_TABLE
            veh[i, V_BTAB] = append_table(tables, [*tab[:, 0], *tab[:, 1]])
            veh[i, V_BNTAB] = len(tab)
        elif vb.friction == "karwatzki":
            veh[i, V_BFRIC] = FRICTION_KARWATZKI
        else:
            veh[i, V_BFRIC] = FRICTION_CONSTANT
            veh[i, V_BMU] = float(vb.friction)
        if b.mode == "pneumatic" and not fluid:
            veh[i, V_BDELAY] = min(abs(p0[i] - c) for c in control_points) / b.propagation_speed
    fluid_extra = {}
    if air is not None:
        fluid_extra, ny = _fluid_states(air, len(shoe_forces), len(control), ny, y0_extra,
                                        kinds)
        braked = veh[:, V_BZ] >= 0
        veh[braked, V_BZ] += 3 * fluid_extra["pipe_dx_cell"].size - 1  # (the pipe before)
        drv[D_BMODEL] = BRAKE_FLUID
    for key, col_off, col_len in (("time", D_BSOFF, D_BSLEN),
                                  ("position", D_BPOFF, D_BPLEN)):
        rows = brake_schedule(s, key, air["dv_row"] if air is not None else None)
        if rows:
            arr = np.asarray(rows, dtype=float)  # (m, N_EVENT_COLUMNS)
            drv[col_off] = append_table(tables, arr.T.ravel())  # each column in turn
            drv[col_len] = len(arr)
    drv[D_BCTRL] = 1.0 if d.brake_controller else 0.0
    drv[D_BSTEP] = b.level_step
    drv[D_BTAUA], drv[D_BTAUR], drv[D_BVS] = (b.apply_time_constant, b.release_time_constant,
                                              b.standstill_speed)
    drv[D_BSHOEREF] = float(np.mean(shoe_forces)) if shoe_forces else 0.0
    drv[D_BFULLSUM] = float(veh[:, V_BFULL].sum())

    y0 = np.zeros(ny)
    y0[n:2 * n] = s.initial.speed if s.initial.velocities is None else s.initial.velocities
    y0[2 * n:] = y0_extra
    sv = s.solver
    scale = {"x": sv.atol, "v": sv.atol, "speed": sv.atol * SPEED_SCALE,
             "force": sv.atol * FORCE_SCALE, "fill": sv.atol,
             "pressure": sv.atol * PRESSURE_SCALE, "flow": sv.atol * FLOW_SCALE,
             "density": sv.atol * DENSITY_SCALE,
             "position": sv.atol,
             # running totals of what the other states do; they feed nothing back
             "exhausted": np.inf, "energy": np.inf}
    scale.update({"flux": sv.atol, "volt": sv.atol * VOLT_SCALE,
                  "omega": sv.atol, "torque": sv.atol * FORCE_SCALE})
    no_rtol = ("x", "exhausted", "energy")
    if sv.speed_atol is not None:  # the speeds held to an absolute tolerance alone
        scale["speed"] = sv.speed_atol
        no_rtol += ("speed",)
    atol = np.array([scale[k] for k in kinds])
    atol[gear_f1] = sv.atol * GEAR_FORCE_SCALE
    rtol = np.array([0.0 if k in no_rtol else sv.rtol for k in kinds])
    return Lowered(
        veh=veh, cons=cons, cpl_model=cpl_model, cpl=cpl,
        track_pos=track_pos, track_grade=track_grade, track_curv=track_curv,
        curve_h=float(s.track.curve_h), trac=trac, drv=drv,
        prof_t=np.ascontiguousarray(prof[:, 0]), prof_y=np.ascontiguousarray(prof[:, 1]),
        ctab=np.array(tables, dtype=float),
        tableau=BS23 if sv.adaptive else get_tableau(sv.method), dt=float(sv.dt),
        n_steps=sv.n_steps, record_every=sv.record_every,
        energy_every=sv.energy_every, y0=y0,
        atol=atol, rtol=rtol, max_step=float(sv.max_step),
        air_max_step=float(sv.air_max_step), adaptive=sv.adaptive, energy=sv.energy,
        gear_f1=np.array(gear_f1, dtype=np.int64), gear_of=np.array(gear_of, dtype=np.int64),
        gear_plate=np.array(gear_plate, dtype=np.int64),
        gear_exact=np.array(gear_exact, dtype=np.int64),
        hold_speed=float(sv.hold_speed or 0.0) if sv.adaptive else 0.0, hold_f=hold_f,
        hold_ftol=sv.atol * GEAR_FORCE_SCALE,
        **fluid_extra, **_drive_fields(drive_rows, len(consists)),
    )


#: what each of an induction-drive consist's states is, for the bs23 error weights: the
#: drive's (foc.DRIVE_STATES: four flux linkages, the controller's flux, Wb; its two
#: integrators, V), the wheelset's angular speed (rad/s) and the slip controller's limit
#: (N m)
DRIVE_KINDS = ["flux"] * 5 + ["volt"] * 2 + ["omega", "torque"]
N_DRIVE_STATES = len(DRIVE_KINDS)
#: V: the current controllers' integrators enter the error weights as atol x 1e3 V
#: (atol 1e-6 -> 1 mV against the 1259 V limit)
VOLT_SCALE = 1.0e3


def _drive_rows(s: Scenario, loco, k: int, z: int) -> dict:
    """The parameter rows and initial state of consist ``k``'s induction drive with its
    states at ``z``: one motor, controller, wheelset and slip controller stand for each
    of the consist's ``per_locomotive x vehicles`` motors (they share the consist's speed
    and demand, so they run alike)."""
    from ltdsim.scenario import creep as creep_schema
    from ltdsim.physics.drive import foc
    from ltdsim.physics.drive.induction import motor_row

    t = s.traction
    motor = t.motor.motor()
    m = motor_row(motor)
    c = foc.controller_row(motor)
    ws = t.creep.wheelset
    mass = float(np.mean([s.vehicles[i].weight_mass for i in loco.vehicles]))
    wrow = creep_schema.wheelset_row(ws, mass, s.track.gravity, motor.rotor_inertia)
    rail = creep_schema.rail_row(t.creep.rail)
    # the largest motor torque: the current limit at rated flux (foc.drive_rates)
    kt = 1.5 * c[foc.C_P] * c[foc.C_LM] ** 2 / c[foc.C_LR]
    id0 = c[foc.C_PSI0] / c[foc.C_LM]
    t_lim = kt * id0 * np.sqrt(max(c[foc.C_IMAX] ** 2 - id0 ** 2, 0.0))
    t_max = ws.gear_ratio * ws.gear_efficiency * t_lim
    slip = creep_schema.slip_row(t.creep.slip_control, wrow, t_max)
    n_motors = t.motor.per_locomotive * len(loco.vehicles)
    v0 = (s.initial.speed if s.initial.velocities is None
          else s.initial.velocities[loco.vehicles[0]])
    # the drive starts in its steady state at the initial speed and demand (the wheels
    # rolling: no creep), not magnetised at standstill (docs/induction-drive-train.md)
    om0 = v0 / ws.wheel_radius
    t_ref = _initial_torque_demand(_initial_demand(s, k, v0), v0, om0, t_max, n_motors,
                                   wrow, slip, t)
    y_drive = foc.drive_steady(m, c, ws.gear_ratio * om0, t_ref, motor.dc_link_voltage)
    y0 = [*y_drive, om0, t_max]
    # peak line current -> rms winding current
    to_rms = 1.0 / np.sqrt(2.0) / (np.sqrt(3.0) if motor.connection == "delta" else 1.0)
    misc = np.array([float(n_motors), ws.gear_efficiency, motor.dc_link_voltage,
                     1.0 if t.creep.slip_control.enabled else 0.0, to_rms,
                     float(t.motor.per_locomotive), t.brake_fade])
    return {"cons": k, "z": z, "motor": m, "ctrl": c, "ws": wrow, "rail": rail,
            "slip": slip, "misc": misc, "y0": y0}


def _initial_demand(s: Scenario, k: int, v0: float) -> float:
    """Consist ``k``'s traction demand at t = 0 (N, + traction) at its lead vehicle's
    speed ``v0`` (m/s), by the law of ``kernel._traction``: in force mode the force
    profile at 0 (linear, constant before its first point) times the consist's share
    ``max_force / sum of the followers' max_force``; in notch mode, or on the
    consist's own notch schedule, the notch held at 0 over 8 times its traction curve
    at ``v0``. In speed mode 0: the speed controller's first output is not evaluated
    here (the drive follows it from the steady state of no torque, as it follows any
    later step of the demand)."""
    from ltdsim.physics.drive.traction import traction_max

    t = s.traction
    d = s.driver
    consists = s.consists()
    loco = consists[k]

    def pick(lc, key):
        own = getattr(lc, key)
        return getattr(t, key) if own is None else own

    def held(points):  # the step function at 0: the last point at or before it
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        j = max(int(np.searchsorted(pts[:, 0], 0.0, side="right")) - 1, 0)
        return float(pts[j, 1])

    lim = float(traction_max(v0, pick(loco, "max_force"), pick(loco, "max_power"),
                             pick(loco, "adhesion_mass"), s.track.gravity))
    if loco.notch_profile is not None:
        return held(loco.notch_profile) / 8.0 * lim
    if d.mode == "notch":
        return held(d.notch_profile) / 8.0 * lim
    if d.mode == "force":
        pts = np.asarray(d.force_profile, dtype=float).reshape(-1, 2)
        f0 = float(np.interp(0.0, pts[:, 0], pts[:, 1]))
        fmax = [pick(lc, "max_force") for lc in consists if lc.notch_profile is None]
        return f0 * pick(loco, "max_force") / float(np.sum(fmax))
    return 0.0


def _initial_torque_demand(dem: float, v0: float, om0: float, limit: float,
                           n_motors: int, wrow: np.ndarray, slip: np.ndarray,
                           t) -> float:
    """The motor's torque demand (N m at the shaft) from a consist demand ``dem`` (N)
    at vehicle speed ``v0`` (m/s), wheelset speed ``om0`` (rad/s) and the slip
    controller's limit ``limit`` (N m at the wheel), by the law of ``kernel._drive_axle``
    (docs/induction-drive-train.md, steps 2-4): a braking demand faded below
    ``Traction.brake_fade`` (:func:`ltdsim.physics.drive.traction.braking_share`); the wheel torque ``dem r / motors``; the slip controller
    (:func:`ltdsim.physics.drive.creep.slip_control`, mirrored in braking); over ``G eta``
    (motoring) or times ``eta / G`` (braking)."""
    from ltdsim.physics.drive import creep as _creep

    if dem < 0.0:
        dem *= braking_share(v0, t.brake_fade)
    r = wrow[_creep.WS_R]
    tw = dem * r / n_motors
    if t.creep.slip_control.enabled:
        if tw >= 0.0:
            tw, _ = _creep.slip_control(limit, tw, om0, v0, r, slip)
        else:
            tw, _ = _creep.slip_control(limit, -tw, -om0, -v0, r, slip)
            tw = -tw
    g, eta = wrow[_creep.WS_I], t.creep.wheelset.gear_efficiency
    return tw / (g * eta) if tw >= 0.0 else tw * eta / g


def _drive_fields(rows: list[dict], n_cons: int) -> dict:
    """The ``Lowered`` fields of the induction drives (empty rows without any)."""
    from ltdsim.physics.drive import creep as _creep
    from ltdsim.physics.drive import foc
    from ltdsim.physics.drive.induction import N_MOTOR_PARAMS

    of = np.full(n_cons, -1, np.int64)
    for j, r in enumerate(rows):
        of[r["cons"]] = j

    def stack(key, width):
        return (np.array([r[key] for r in rows], dtype=float) if rows
                else np.zeros((0, width)))
    return {"drive_of": of,
            "drive_z": np.array([r["z"] for r in rows], dtype=np.int64),
            "drive_motor": stack("motor", N_MOTOR_PARAMS),
            "drive_ctrl": stack("ctrl", foc.N_CTRL_PARAMS),
            "drive_ws": stack("ws", _creep.N_WHEELSET_PARAMS),
            "drive_rail": stack("rail", _creep.N_CREEP_PARAMS),
            "drive_slip": stack("slip", _creep.N_SLIP_PARAMS),
            "drive_misc": stack("misc", N_DRIVE_MISC)}



def service_pressure(cv_row: np.ndarray, dv_row: np.ndarray, reduction: float) -> float:
    """Brake-cylinder pressure, Pa gauge, that the control valve ``cv_row``
    (:data:`ltdsim.physics.air.brakevalves.CV_PARAMS`) settles at after a service
    reduction of ``reduction`` Pa from the regulated pressure of the driver's valve
    ``dv_row`` (``DV_PARAMS``).

    UIC (three-pressure) valves: the graduated law, ``max_cylinder`` from ``full_drop``
    on. AAR (triple-valve) valves: the auxiliary reservoir's air that the reduction ``r``
    moves into the cylinder, ``r V_aux / V_cyl``, at most the equalisation of the two
    volumes from the regulated pressure ``p_reg``, ``p_reg V_aux / (V_aux + V_cyl)``
    (Boyle's law at constant temperature; the quick-service draw from the pipe is left
    out)."""
    from ltdsim.physics.air.brakevalves import CV_PARAMS, DV_PARAMS, FAMILY_UIC
    from ltdsim.scenario.brakes import equalisation_pressure

    cv = dict(zip(CV_PARAMS, cv_row))
    dv = dict(zip(DV_PARAMS, dv_row))
    if cv["family"] == FAMILY_UIC:
        span = cv["full_drop"] - cv["threshold"]
        return float(cv["max_cylinder"] * min(max((reduction - cv["threshold"]) / span, 0.0),
                                              1.0))
    va, vc = cv["auxiliary_volume"], cv["cylinder_volume"]
    return float(min(reduction * va / vc, equalisation_pressure(dv["regulated"], va, vc)))


def full_service_pressure(cv_row: np.ndarray, dv_row: np.ndarray) -> float:
    """Brake-cylinder pressure of a full service, Pa gauge (:func:`service_pressure` of
    the driver's valve's ``full_reduction``: a UIC valve's ``max_cylinder``, since the
    valve tables' relations keep ``full_drop`` within the full reduction)."""
    from ltdsim.physics.air.brakevalves import DVP_FULL

    return service_pressure(cv_row, dv_row, dv_row[DVP_FULL])


def _fluid_rows(s: Scenario, lengths: np.ndarray, control: list[int]) -> dict:
    """The fluid brake's valve rows, initial valve states, pipe grid, cell volumes and gas
    row."""
    from ltdsim.physics.air.brakepipe import (
        THERMAL_MODES, air_conductivity, air_viscosity, cell_volumes, pipe_geometry)
    from ltdsim.physics.air.brakevalves import (
        CVP_VBRANCH, DV_PARAMS, control_valve_init, control_valve_row, driver_valve_init,
        driver_valve_row)
    from ltdsim.scenario import valve_tables

    fl = s.brake.fluid
    a = s.brake.air
    cv_table, dv_table = valve_tables(fl)
    cv_row = control_valve_row(cv_table)
    dv_row = driver_valve_row(dv_table)
    p_abs = a.atmosphere + float(dv_table["regulated"])
    geom = pipe_geometry(lengths, fl.cells_per_vehicle)
    gas = np.zeros(N_AIR)
    viscosity = air_viscosity(a.temperature) if a.viscosity is None else a.viscosity
    gas[[A_GAMMA, A_RGAS, A_TEMP, A_ATM, A_RLIN, A_VISC]] = (
        a.gamma, a.gas_constant, a.temperature, a.atmosphere, a.linear_ratio, viscosity)
    gas[A_AREA] = np.pi * fl.pipe_diameter ** 2 / 4.0
    gas[A_DIAM] = fl.pipe_diameter
    gas[A_ROUGH] = fl.roughness
    gas[A_THERMAL] = THERMAL_MODES.index(a.thermal)
    gas[A_COND] = air_conductivity(a.temperature) if a.conductivity is None else a.conductivity
    # every vehicle's hoses beyond the bore; a braked one's branch pipe and valve bracket
    side = np.array([fl.hose_volume + (cv_row[CVP_VBRANCH] if v.brake is not None else 0.0)
                     for v in s.vehicles])
    cv_init = control_valve_init(p_abs, cv_row, a.atmosphere)
    dv_init = driver_valve_init(p_abs, dv_row, a.atmosphere)
    return {
        "geometry": geom, "gas": gas, "p_abs": p_abs, "cv_row": cv_row, "dv_row": dv_row,
        "volume": cell_volumes(geom.dx_cell, gas[A_AREA], side, fl.cells_per_vehicle),
        "rho": p_abs / (a.gas_constant * a.temperature),
        "cv_init": [float(x) for x in cv_init], "dv_init": [float(x) for x in dv_init],
        # a state that starts at a pressure (Pa abs) is one; the others are positions (-)
        "cv_kinds": [_valve_kind(x) for x in cv_init],
        "dv_kinds": [_valve_kind(x) for x in dv_init],
        "full_service": full_service_pressure(cv_row, dv_row),
        "leak": np.full(geom.dx_cell.size, fl.leakage / fl.cells_per_vehicle),
        "dv_cell": np.array([geom.vehicle_first[i] for i in control], dtype=np.int64),
        "viscosity": viscosity,
        "p_main": a.atmosphere + float(dict(zip(DV_PARAMS, dv_row))["main_initial"]),
    }


def lower_fluid_parts(s: Scenario) -> dict:
    """The fluid brake's pipe grid (``geometry``), valve rows (``cv_row``, ``dv_row``),
    leak per cell (``leak``, m^2), cell volumes (``volume``, m^3), charged pipe pressure
    (``p_abs``) and density (``rho``, kg/m^3), gas row (``gas``, layout.AIR_SLOTS) and
    main-reservoir pressure (``p_main``, Pa abs) of scenario ``s`` (``brake.model =
    "fluid"``), without lowering the rest (the step check's input)."""
    lengths = np.array([v.length for v in s.vehicles])
    return _fluid_rows(s, lengths, _brake_control_vehicles(s.consists()))


def _brake_control_vehicles(consists) -> list[int]:
    """Vehicle indices of the brake-control points: the lead consist's first vehicle and
    that of every other consist with ``brake_control`` (the remotes)."""
    return [consists[0].vehicles[0]] + [
        loco.vehicles[0] for k, loco in enumerate(consists) if k > 0 and loco.brake_control]


def _valve_kind(x0: float) -> str:
    """Error-scale kind of a valve state from its initial value: a pressure (Pa abs,
    at least a tenth of an atmosphere) or a position (-)."""
    return "pressure" if x0 > 1.0e4 else "position"


def _fluid_states(air: dict, n_valves: int, n_control: int, ny: int, y0_extra: list,
                  kinds: list) -> tuple[dict, int]:
    """Append the pipe, driver's-valve and exhausted-air states after the control valves
    (already appended at ``[ny - n_valves N_CV, ny)``); returns the ``Lowered`` fields
    of the fluid brake and the new state count. Layout (common15.md): pipe cell
    pressures (nc), face flows (nc - 1), cell densities (nc), control valves, driver's
    valves, exhausted air."""
    geom = air["geometry"]
    nc = geom.dx_cell.size
    n_cv = len(air["cv_init"])
    z_cv = ny - n_valves * n_cv
    # the pipe goes in front of the control valves: shift their indices
    index = np.zeros(N_AIR_INDEX, dtype=np.int64)
    index[I_PIPE] = z_cv
    index[I_CELLS] = nc
    index[I_CV] = z_cv + 3 * nc - 1
    pipe = [air["p_abs"]] * nc + [0.0] * (nc - 1) + [air["rho"]] * nc
    at = len(y0_extra) - n_valves * n_cv
    y0_extra[at:at] = pipe
    k_at = len(kinds) - n_valves * n_cv
    kinds[k_at:k_at] = ["pressure"] * nc + ["flow"] * (nc - 1) + ["density"] * nc
    ny += 3 * nc - 1
    index[I_DV] = ny
    for _ in range(n_control):
        y0_extra.extend(air["dv_init"])
        kinds.extend(air["dv_kinds"])
    ny += n_control * len(air["dv_init"])
    index[I_EXH] = ny
    y0_extra.append(0.0)
    kinds.append("exhausted")
    ny += 1
    index[I_NCP] = n_control
    return {
        "air_gas": air["gas"], "air_index": index,
        "pipe_dx_cell": np.ascontiguousarray(geom.dx_cell, dtype=float),
        "pipe_dx_face": np.ascontiguousarray(geom.dx_face, dtype=float),
        "pipe_leak": air["leak"],
        "pipe_volume": np.ascontiguousarray(air["volume"], dtype=float),
        "cv_rows": np.tile(air["cv_row"], (n_valves, 1)),
        "dv_rows": np.tile(air["dv_row"], (n_control, 1)),
        "dv_cell": air["dv_cell"],
    }, ny


def brake_schedule(s: Scenario, key: str, dv_row: np.ndarray | None) -> list[list[float]]:
    """The driver's brake commands by ``key`` ("time" s or "position" m of the lead),
    sorted: ``brake_profile`` (or ``brake_positions``) and ``brake_commands``, each as
    ``[key, level, kind, value]`` (:data:`N_EVENT_COLUMNS`, ``CMD_*`` kinds). The lumped
    brake (``dv_row`` None) takes handles as levels (release 0, minimum
    ``brake.minimum_level``, full, suppression and handle-off 1, emergency
    ``brake.emergency_level``, fast fill 0,
    lap the level before); the fluid brake a level L as a service reduction of L x the
    full-service one (0: release), a handle as the driver's valve's position or
    reduction (``dv_row``, ``DV_PARAMS``; suppression: full service; handle-off: the
    whole regulated pressure at the service rate)."""
    d = s.driver
    points = d.brake_profile if key == "time" else d.brake_positions
    rows = [[float(x), float(level), float(CMD_LEVEL), 0.0] for x, level in points or []]
    full = minimum = 0.0
    if dv_row is not None:
        from ltdsim.physics.air.brakevalves import DV_PARAMS

        dv = dict(zip(DV_PARAMS, dv_row))
        full, minimum = float(dv["full_reduction"]), float(dv["minimum_reduction"])
        regulated = float(dv["regulated"])
    cmds = sorted((c for c in d.brake_commands or [] if getattr(c, key) is not None),
                  key=lambda c: getattr(c, key))
    for c in cmds:
        x = float(getattr(c, key))
        if dv_row is None:  # lumped: levels (a reduction is refused on load)
            if c.handle == "lap":  # holds the level of the command before (applied later)
                rows.append([x, -1.0, float(CMD_LEVEL), 0.0])
                continue
            level = {"release": 0.0, "fast-fill": 0.0, "minimum": s.brake.minimum_level,
                     "full": 1.0, "suppression": 1.0, "handle-off": 1.0,
                     "emergency": s.brake.emergency_level}[c.handle]
            rows.append([x, level, float(CMD_LEVEL), 0.0])
            continue
        if c.reduction is not None:
            red = float(c.reduction)
        elif c.handle in ("minimum", "full", "suppression"):
            red = minimum if c.handle == "minimum" else full
        elif c.handle == "handle-off":  # (26L: the pipe to zero at the service rate)
            red = regulated
        else:
            red = 0.0
        if c.handle == "emergency":
            rows.append([x, 1.0, float(CMD_EMERGENCY), 0.0])
        elif c.handle == "lap":
            rows.append([x, -1.0, float(CMD_LAP), 0.0])
        elif c.handle == "fast-fill":
            rows.append([x, 0.0, float(CMD_FAST_FILL), 0.0])
        elif red <= 0.0:
            rows.append([x, 0.0, float(CMD_RELEASE), 0.0])
        else:
            rows.append([x, min(red / full, 1.0), float(CMD_SERVICE), red])
    rows.sort(key=lambda r: r[0])  # (stable: a profile point before a command at one time)
    level = 0.0
    for r in rows:  # a lap holds the level in force before it (its recorded command)
        if r[1] < 0.0:
            r[1] = level
        level = r[1]
    return rows


def rounded_profile(points, step: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """The speed reference as piecewise-linear ``(t, v)`` arrays (s, m/s).

    ``points`` are ``[t, v]`` or ``[t, v, T]``. A jerk time ``T`` (s) rounds the corner at
    that point: over ``T`` centred on it the acceleration changes linearly from the slope
    before to the slope after (constant jerk ``(a_after - a_before) / T``), so the speed
    follows a parabola tangent to both straight segments, which are kept outside the
    rounding. The parabola is sampled every ``step`` s or finer (the largest speed
    error of the sampling is ``jerk x step^2 / 8``). Without jerk times the points are
    returned as they are.
    """
    t = np.array([p[0] for p in points], dtype=float)
    v = np.array([p[1] for p in points], dtype=float)
    blend = np.array([p[2] if len(p) == 3 else 0.0 for p in points], dtype=float)
    if not (blend > 0.0).any():
        return t, v
    slope = np.diff(v) / np.diff(t)
    out_t, out_v = [t[0]], [v[0]]
    for k in range(1, t.size):
        if k < t.size - 1 and blend[k] > 0.0:
            a0, a1, T = slope[k - 1], slope[k], blend[k]
            ts = t[k] - 0.5 * T
            n = max(int(np.ceil(T / step)), 2)
            tau = np.linspace(0.0, T, n + 1)
            # v(ts + tau) on the incoming line, plus the parabola of the changing slope
            vs = v[k] - a0 * 0.5 * T + a0 * tau + 0.5 * (a1 - a0) * tau**2 / T
            out_t.extend(ts + tau)
            out_v.extend(vs)
        else:
            out_t.append(t[k])
            out_v.append(v[k])
    t_out, v_out = np.array(out_t), np.array(out_v)
    keep = np.concatenate([[True], np.diff(t_out) > 1e-12])  # touching rounded corners
    return t_out[keep], v_out[keep]


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
