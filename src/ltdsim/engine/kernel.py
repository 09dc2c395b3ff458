"""The compiled simulation loop: right-hand side, controller and Runge-Kutta stepping.

Everything here runs under numba. The kernels :func:`run` and :func:`run_adaptive`
take a handful of named structures (``NamedTuple`` classes of arrays, below): the
:class:`Train`, its :class:`Couplers`, the :class:`Driver`, the :class:`Controller`'s
state, the step grid (:class:`FixedStep` or :class:`Adaptive`), the :class:`Work`
arrays and the :class:`Outputs`. Their tables are flat arrays whose columns
:mod:`ltdsim.engine.layout` (vehicles, consists, traction, driver) and
:mod:`ltdsim.engine.couplers` (couplers, whose force comes from that module's compiled
dispatch :func:`~ltdsim.engine.couplers.coupler_force`) lay out; the states that carry
over between calls (controller, bs23 step control, the right-hand side's signals) are
numpy records with named fields (``CONTROLLER``, ``STEPPER``, ``SIGNALS``), read as
``st["a_dem"]``, a form that also runs as plain Python (``NUMBA_DISABLE_JIT=1``).
Numba compiles a kernel once per set of argument types and finds it in its on-disk
cache by the classes' import names, so the classes live here at module level.

The state vector is ``y = [x_0..x_(n-1), v_0..v_(n-1), z...]``: displacement of each
vehicle from its initial position (m), its speed (m/s), and the internal states of the
hysteretic draft gears (internal force N; wedge gears also the plate displacement m,
and with an S table the impact speed m/s; see :mod:`ltdsim.physics.gears.draftgear`), then
the traction lags and the brake-cylinder fills. The discrete PID is sampled between
steps and its output held over the step (zero-order hold), as a digital controller is;
every continuous quantity is a pure function of ``(t, y)``, so any Runge-Kutta method
can evaluate it any number of times per step.

The right-hand side :func:`rhs` calls one function per subsystem, in this order:
:func:`_resistance` (running, grade and curve resistance per vehicle), :func:`_brakes`
(brake-cylinder fills and shoe forces), :func:`_traction` (the driver's demand and each
locomotive consist's force and lag), :func:`_induction` (the consists on the induction
drive), :func:`_couplers` (each coupler's force through
:func:`ltdsim.engine.couplers.coupler_force`, the registry's dispatch) and
:func:`_force_balance` (each vehicle's acceleration). They
pass their results through the :class:`Work` arrays (``res``, ``bforce``, ``fcons``,
``force``, ``defl``, ``sig``) and write their states' rates to ``dy``.

Stepping. One stage routine, :func:`_stages`, computes the stages of any explicit
Runge-Kutta tableau for any right-hand side passed to it as a compiled function (numba
compiles it once per right-hand side): the train's (:func:`_train_rhs`) in :func:`run`
and :func:`run_adaptive`, the gear rig's in :mod:`ltdsim.analysis.gears`. :func:`_advance` ends a
fixed step (``run`` and the rig); the adaptive kernel forms the bs23 solution and error
from the tableau's ``b`` and ``e`` weights, its three stages written out in one pass
over the state each (fewer instructions than a pass per stage). Both train kernels
sample the controller on one clock, :func:`_sample_due`.

Per-step work. The fixed-step kernel checks the state for non-finite values at record
steps and at the end of each call, not after every step: such values persist (every
later step adds to them), so the next check finds them, and the error names the
interval between the last good check and the failing one. :func:`_advance` writes the
step's end out for three and four stages (ode3, rk4), one pass over the state. Couplers
that all share the simplified model (``Couplers.uniform``) run a loop of their own, in
which the compiler knows the model and drops the dispatch and the gear code. Each was
kept because it cut the instructions per step of the force-mode base train
(benchmarks/bench_reference_instructions.py, against the hand-written kernel of
benchmarks/reference_kernel.py) with every result bit unchanged; a branch-free or
pre-checked peak tracking and a force balance in separate vectorisable passes measured
worse and were left out.
A vehicle's grade force and curve resistance are worked out when it enters a piece of
track and kept in the :class:`Work` (``tkey``, ``tres``), not at every evaluation. In
:func:`run_adaptive` the step's finite check is a flag instead of a running sum, the
slack test's stage weights are formed once per step, and the gears that spend a step in
their slack share one exponential per relaxation rate. Together they cut the
instructions per attempted step of the heavy-haul train in cruise by 10 % (callgrind,
2026-12-01) with every result bit unchanged (benchmarks/check_bit_identical.py); error
ratios formed in a pass of their own before their maximum measured 1 % worse (the
division does not vectorise there, likely because numba's default error model tests it
for zero) and were left out.

Compiling. The small helpers are inlined by numba into their callers
(``inline="always"``). The large ones (:func:`rhs` and its subsystems,
:func:`~ltdsim.engine.couplers._gear`, :func:`_record`, :func:`_controller`,
:func:`_brake_commands`, :func:`_stages` and the right-hand sides it is given) are compiled once each and inlined by LLVM instead
(``forceinline=True``; the subsystems inlined by numba ran 2.4 % more instructions in
the fixed-step kernel): numba's own inlining copies and types a function's whole body
again at every call site, and with the right-hand side then called from three places in
:func:`run` and four in :func:`run_adaptive` their first compile took about 140 s and
200 s of CPU (now about 17 s each, and the second shares most of the first). The
compiled kernels hold no calls to these functions: the machine code does the same work
as before. The one exception is the induction drive's :func:`_drive_axle`, a plain
compiled function that :func:`_induction` calls: inlined into every copy of the
right-hand side it added about half to the kernels' first compile. No argument of these functions may be a constant at a call site either: numba
compiles a function once per set of argument types, and a constant such as ``0`` or
``True`` is a type of its own (hence the stage slices ``K[s * ny:(s + 1) * ny]`` rather
than an offset ``0``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ltdsim.engine.couplers import (
    M_SIMPLIFIED,
    P_D0,
    P_F0,
    P_RATE,
    P_SLACK,
    W_BACK,
    W_GAP,
    coupler_force,
)
from ltdsim.physics.gears.draftgear import plate_rate, relax
from ltdsim.engine.layout import (
    DM_FADE,
    DM_GEAR_EFF,
    DM_MOTORS,
    DM_PER_LOCO,
    DM_SLIP_ON,
    DM_TO_RMS,
    DM_VDC,
    DS_CREEP,
    DS_CURRENT,
    DS_FORCE,
    DS_PDC,
    DS_PRD,
    DS_PRQ,
    DS_PSD,
    DS_PSQ,
    DS_SPEED,
    DS_TORQUE,
    N_DRIVE_SIGNALS,
    A_AREA,
    A_ATM,
    A_DIAM,
    A_GAMMA,
    A_RGAS,
    A_RLIN,
    A_ROUGH,
    A_TEMP,
    A_VISC,
    BRAKE_FLUID,
    CMD_EMERGENCY,
    CMD_LEVEL,
    CMD_RELEASE,
    D_BMODEL,
    EV_KIND,
    EV_LEVEL,
    EV_TIME,
    EV_VALUE,
    I_CELLS,
    I_DV,
    I_EXH,
    I_NCP,
    I_PIPE,
    V_BAREA,
    V_BCELL,
    V_BCV,
    V_BGAIN,
    V_BINVSHOES,
    V_BPFS,
    V_BSPRING,
    D_BCTRL,
    D_BFULLSUM,
    D_BPLEN,
    D_BPOFF,
    D_BSHOEREF,
    D_BSLEN,
    D_BSOFF,
    D_BSTEP,
    D_BTAUA,
    D_BTAUR,
    D_AW,
    D_BVS,
    D_FILT,
    D_INT,
    D_KD,
    D_KI,
    D_KP,
    D_MODE,
    D_N,
    E_AIR,
    E_CURVE,
    E_DAVIS,
    E_DYN,
    E_GRADE,
    E_MOTOR,
    N_ENERGY,
    D_TS,
    K_DBFADE,
    K_FMAX,
    K_MADH,
    K_NLEN,
    K_NOFF,
    K_PMAX,
    K_RATE,
    K_SHARE,
    K_TAU,
    K_VEH,
    K_Z,
    MODE_FORCE,
    MODE_NOTCH,
    MODE_SPEED,
    T_AMAX,
    T_DMAX,
    T_EZ,
    T_FF,
    T_G,
    T_MTOT,
    T_REF,
    V_BDELAY,
    V_BFRIC,
    V_BFULL,
    V_BMU,
    V_BNTAB,
    V_BSHOE,
    V_BTAB,
    V_BZ,
    V_CONS,
    V_DA,
    V_DB,
    V_DC,
    V_DIV0,
    V_MASS,
    V_P0,
    V_SHARE,
    V_WMASS,
)
from ltdsim.physics.air.brakes import (
    FRICTION_CONSTANT,
    FRICTION_KARWATZKI,
    karwatzki_mu,
    retarding_force,
)
from ltdsim.physics.air.brakepipe import pipe_rates
from ltdsim.physics.air.brakevalves import (
    CV_STATES,
    DV_STATES,
    H_EMERGENCY,
    H_RELEASE,
    H_SERVICE,
    DV_PARAMS,
    control_valve,
    driver_valve,
    driver_valve_compressor,
)
from ltdsim.physics.control import PID_STATE, pid_step
from ltdsim.physics.resistance import (
    curve_force,
    davis_force,
    grade_force,
)
from ltdsim.physics.drive.traction import adhesion_max, traction_max
from ltdsim.physics.drive.creep import W_I, W_R, W_VREG, slip_control, wheelset_rate
from ltdsim.physics.drive.foc import N_DRIVE, N_OUT, O_ID, O_IQ, O_PDC, drive_rates
from ltdsim.physics.drive.induction import S_PRD, S_PRQ, S_PSD, S_PSQ

#: kernel return codes
OK, NONFINITE, EVENTS_FULL = 0, 1, 2
#: columns of the recorded scalar signals
S_TRACTION, S_VREF, S_ADHESION, S_ADEM, S_DEMAND, S_BRAKE = range(6)
N_SCALARS = 6
#: columns of the peak-force table, one row per coupler: largest force N, smallest
#: force N, time of the largest s, time of the smallest s
PK_MAX, PK_MIN, PK_TMAX, PK_TMIN = range(4)
N_PEAKS = 4
#: the brake-command store has one row per command, ``EV_*`` columns
#: (:data:`ltdsim.engine.layout.EVENT_COLUMNS`: time issued s, level 0-1, kind, value)
#: states of a control valve and of a driver's valve (:mod:`ltdsim.physics.air.brakevalves`)
N_CV = len(CV_STATES)
N_DV = len(DV_STATES)
CV_AUX = CV_STATES.index("auxiliary")
CV_CYL = CV_STATES.index("cylinder")
DV_FULL = DV_PARAMS.index("full_reduction")

#: signals of the last right-hand-side evaluation (one record, in :class:`Work`):
#: total traction force N, traction demand before the traction-curve limits N, total
#: running resistance N
SIGNALS = np.dtype([("traction", np.float64), ("demand", np.float64),
                    ("resistance", np.float64)])
#: controller state (one record, in :class:`Controller`): demanded acceleration held
#: between samples m/s^2, last reference speed m/s, brake commands issued, last
#: commanded brake level (0-1), next scheduled brake command and next position trigger
#: (indices into their lists), next controller sample (count of samples, bs23)
CONTROLLER = np.dtype([("a_dem", np.float64), ("v_ref", np.float64),
                       ("n_events", np.int64), ("level", np.float64),
                       ("next_scheduled", np.int64), ("next_position", np.int64),
                       ("next_sample", np.int64)])
#: bs23 state carried over between calls of :func:`run_adaptive` (one record): step
#: size s, accepted and rejected steps, time of the current state s, error of the last
#: accepted step (scaled, 1 = at the tolerance), whether the last step was rejected
STEPPER = np.dtype([("h", np.float64), ("accepted", np.int64), ("rejected", np.int64),
                    ("t", np.float64), ("last_error", np.float64),
                    ("last_rejected", np.bool_)])

#: the fluid brake's own bs23 stepping in :func:`run_adaptive` (one record, in
#: :class:`Work`): start and end of the current pneumatic step s, the next step size s,
#: error of the last accepted step (scaled), whether the last step was rejected, steps
#: accepted and rejected, whether the stepping has started, start of the previous
#: pneumatic step s (which ends at ``t0``; equal to ``t0`` when it is not kept)
AIR_STEPPER = np.dtype([("t0", np.float64), ("t1", np.float64), ("h", np.float64),
                        ("last_error", np.float64), ("last_rejected", np.bool_),
                        ("accepted", np.int64), ("rejected", np.int64),
                        ("started", np.bool_), ("tp", np.float64)])
#: rows of :class:`Work`'s ``air`` array: pneumatic states and rates at the start and end
#: of the current pneumatic step, the pair's second and third stages, a stage state, the
#: states and rates at the start of the previous pneumatic step (its end is the current
#: one's start)
(AIR_Y0, AIR_Y1, AIR_F0, AIR_F1, AIR_K2, AIR_K3, AIR_YT, AIR_YP, AIR_FP) = range(9)
N_AIR_ROWS = 9
#: rows of :class:`Work`'s ``pw`` array: :func:`run` keeps the traction's powers at the
#: step's start, every other power's first sample in the start row, the latest in the
#: end row and the running sums of its samples (:func:`_account_fixed`);
#: :func:`run_adaptive` passes the powers through the start row (:func:`_energy_rates`)
PW_START, PW_END, PW_SUM = 0, 1, 2


class AirBrake(NamedTuple):
    """The fluid-dynamic air brake (``brake.model = "fluid"``; empty arrays for the
    lumped brake): the brake pipe's grid, the valves' parameter rows and where their
    states sit in ``y`` (:mod:`ltdsim.physics.air.brakepipe`, :mod:`~ltdsim.physics.air.brakevalves`)."""

    gas: np.ndarray  # gas and pipe constants, layout.AIR_SLOTS
    index: np.ndarray  # int64 state offsets and counts, layout.AIR_INDEX
    dx_cell: np.ndarray  # (cells,) cell lengths, m
    dx_face: np.ndarray  # (cells - 1,) distances between cell centres, m
    leak: np.ndarray  # (cells,) leak to atmosphere per cell, Cd x area m^2
    cv: np.ndarray  # (braked vehicles, CV_PARAMS) control-valve rows
    dv: np.ndarray  # (brake-control points, DV_PARAMS) driver's-valve rows
    dv_cell: np.ndarray  # (brake-control points,) int64 cell each driver's valve feeds


class Drive(NamedTuple):
    """The induction drives (``traction.drive = "induction"``; empty rows when every
    consist runs on its traction curve): per consist its drive's row or -1, and per
    drive its first state in ``y`` (:data:`ltdsim.engine.lowering.DRIVE_KINDS`: the drive's
    :data:`~ltdsim.physics.drive.foc.DRIVE_STATES`, the wheelset's angular speed rad/s, the
    slip controller's torque limit N m) and its parameter rows."""

    of: np.ndarray  # (consists,) int64 row of each consist's drive, -1: traction curve
    z: np.ndarray  # (drives,) int64 offset of each drive's states in y
    motor: np.ndarray  # (drives, induction.MOTOR_PARAMS) the machine
    ctrl: np.ndarray  # (drives, foc.CTRL_PARAMS) the controller
    ws: np.ndarray  # (drives, creep.WHEELSET_PARAMS) one driven wheelset
    rail: np.ndarray  # (drives, creep.CREEP_PARAMS) the rail condition
    slip: np.ndarray  # (drives, creep.SLIP_PARAMS) the slip controller
    misc: np.ndarray  # (drives, layout.DRIVE_MISC) motors, gear efficiency, DC link, ...


class Train(NamedTuple):
    """The lowered train and track (columns in :mod:`ltdsim.engine.layout`)."""

    veh: np.ndarray  # (n, N_VCOL) vehicles, V_* columns
    powered: np.ndarray  # int64 indices of the powered vehicles (V_SHARE > 0)
    inv_m: np.ndarray  # (n,) inverse vehicle masses, 1/kg
    cons: np.ndarray  # (consists, N_KCOL) locomotive consists, K_* columns
    trac: np.ndarray  # traction and speed-controller constants, T_* slots
    track_pos: np.ndarray  # start of each track segment, m
    track_grade: np.ndarray  # gradient on each segment, rise/run
    track_curv: np.ndarray  # curvature on each segment, 1/m
    curve_h: float  # curve-resistance constant, - (physics.resistance.curve_resistance)
    tables: np.ndarray  # flat store of tables (gear curves, friction, notches, schedules)
    air: AirBrake  # the fluid air brake (empty for the lumped brake)
    drive: Drive  # the induction drives (empty rows without any)


class Couplers(NamedTuple):
    """The lowered couplers, coupler j joining vehicles j and j + 1."""

    model: np.ndarray  # (n - 1,) int64 model codes (ltdsim.engine.couplers.MODEL_NAMES)
    par: np.ndarray  # (n - 1, N_CCOL) parameters (columns: ltdsim.engine.couplers)
    uniform: int  # the model code every coupler has, -1 for a mix (see uniform_model)


class Driver(NamedTuple):
    """The driver: controller and brake constants and the driver's profile."""

    par: np.ndarray  # D_* slots (mode, PID, brake control)
    prof_t: np.ndarray  # times of the profile, s
    prof_y: np.ndarray  # speed m/s, force N or notch (0-8), by mode


class Controller(NamedTuple):
    """What the driver has done so far; updated in place, carried between calls."""

    state: np.ndarray  # one CONTROLLER record
    pid: np.ndarray  # one PID_STATE record (physics.control): integrator, filter states
    events: np.ndarray  # (MAX_EVENTS, N_EVENT_COLUMNS) brake commands issued, EV_* columns


class FixedStep(NamedTuple):
    """A fixed-step explicit Runge-Kutta method and the run's step grid."""

    dt: float  # step, s
    n_steps: int  # steps of the whole run
    record_every: int  # steps between records
    A: np.ndarray  # (stages, stages) Butcher tableau
    b: np.ndarray  # (stages,) weights
    c: np.ndarray  # (stages,) nodes


class Adaptive(NamedTuple):
    """An embedded Runge-Kutta pair under error control (bs23,
    :data:`ltdsim.engine.integrators.BS23`) and the run's record grid. :func:`run_adaptive`
    writes the pair's sums out for its three stages."""

    out_dt: float  # time between records, s
    n_rec: int  # records of the whole run
    h_max: float  # largest step, s
    air_h_max: float  # largest step of the fluid brake's pneumatic states, s
    atol: np.ndarray  # (ny,) absolute error scale per state element (units of the state)
    rtol: np.ndarray  # (ny,) relative tolerance per state element, -
    A: np.ndarray  # (stages, stages) Butcher tableau
    b: np.ndarray  # (stages,) weights of the solution kept
    c: np.ndarray  # (stages,) nodes
    e: np.ndarray  # (stages + 1,) error weights, the last for the step's end (FSAL)
    # the error norm's absolute scales with each hysteretic gear's internal force F1
    # left out (inf): F1 enters through the error of the force the gear exerts
    # (_exerted_error), on the scale atol
    err_atol: np.ndarray  # (ny,)
    gear_f1: np.ndarray  # (gears,) int64: the state index of each gear's F1 in y
    gear_of: np.ndarray  # (gears,) int64: its coupler
    gear_plate: np.ndarray  # (gears,) int64: its plates' state in y, its error taken
    #                         with F1's (then inf in err_atol), or -1
    gear_exact: np.ndarray  # (gears,) int64: 1 if its states relax in the slack to
    #                         constants (_relax_in_slack), else 0


class Work(NamedTuple):
    """Scratch arrays of a kernel call, owned by the caller (see :func:`make_work`)."""

    K: np.ndarray  # stage derivatives, stage s at K[s * ny:(s + 1) * ny] (bs23: 4 stages,
    #                the last the right-hand side at the step's end)
    ytmp: np.ndarray  # (ny,) stage state, then the step's increment
    ynew: np.ndarray  # (ny,) the candidate state of a bs23 step
    force: np.ndarray  # (max(n - 1, 1),) coupler forces, N (+ tension)
    defl: np.ndarray  # (max(n - 1, 1),) coupler deflections, m (+ draft)
    res: np.ndarray  # (n,) running resistance plus air brake per vehicle, N
    bforce: np.ndarray  # (n,) air-brake force per vehicle, N (+ opposing forward motion)
    fcons: np.ndarray  # (consists,) force of each locomotive consist, N
    sig: np.ndarray  # one SIGNALS record
    hints: np.ndarray  # int64 search cursors: [0, n) track, n driver, n + 1 speed profile
    tkey: np.ndarray  # (n,) int64 the track segment of each vehicle's tres row (-1: none)
    tres: np.ndarray  # (n, 2) on that segment its grade force and the magnitude of its
    #                   curve resistance, N (_resistance)
    inflow: np.ndarray  # (pipe cells,) fluid brake: mass flow into each pipe cell, kg/s
    air: np.ndarray  # (N_AIR_ROWS, ny) or (N_AIR_ROWS, 0): the fluid brake's own steps in
    #                  run_adaptive (AIR_* rows; the pneumatic states at their places in y)
    air_step: np.ndarray  # one AIR_STEPPER record
    ddem: np.ndarray  # (drives,) each induction drive's demand, N (from _traction)
    dsig: np.ndarray  # (drives, N_DRIVE_SIGNALS) its signals (layout.DRIVE_SIGNALS)
    dout: np.ndarray  # (drives, foc.N_OUT) its drive_rates outputs (foc.DRIVE_OUTPUTS)
    energy: np.ndarray  # (N_ENERGY + n - 1,) or (0,): the work since the start, J (E_*
    #                     terms, then one per coupler; solver.energy), carried between calls
    #                     (run; run_adaptive integrates them as states)
    pw: np.ndarray  # (3, energy size): the powers at the current step's start and end,
    #                 W, and (run) their running sums (PW_* rows)
    fprev: np.ndarray  # (consists,) the traction force held over the current step, N
    bforce_on: np.ndarray  # (1,) bool: some vehicle has an air brake (its power counts)


class Outputs(NamedTuple):
    """Records (one row per record time) and the peak forces, written by the kernels."""

    x: np.ndarray  # (records, n) track position, m
    v: np.ndarray  # (records, n) speed, m/s
    a: np.ndarray  # (records, n) acceleration, m/s^2
    d: np.ndarray  # (records, n - 1) coupler deflection, m
    f: np.ndarray  # (records, n - 1) coupler force, N
    s: np.ndarray  # (records, N_SCALARS) scalar signals, S_* columns
    b: np.ndarray  # (records, n or 0) air-brake force, N
    p: np.ndarray  # (records, n or 0) brake-cylinder fill, -
    c: np.ndarray  # (records, consists or 0) force of each consist, N
    bp: np.ndarray  # (records, n or 0) fluid brake: pipe pressure at each vehicle, Pa gauge
    ar: np.ndarray  # (records, n or 0) auxiliary reservoir, Pa gauge (NaN: unbraked)
    bc: np.ndarray  # (records, n or 0) brake cylinder, Pa gauge (NaN: unbraked)
    ax: np.ndarray  # (records, 1 or 0) air exhausted to atmosphere so far, kg
    peaks: np.ndarray  # (n - 1, N_PEAKS) peak coupler forces over every step, PK_* columns
    m: np.ndarray  # (records, drives, N_DRIVE_SIGNALS) induction drives' signals (DS_*)
    e: np.ndarray  # (records, N_ENERGY + n - 1 + 1 or 0) the energy states (E_* then one
    #                per coupler), J, and the train's kinetic energy, J (solver.energy)


def make_train(low) -> Train:
    """:class:`Train` of a :class:`~ltdsim.engine.lowering.Lowered` scenario."""
    air = AirBrake(gas=low.air_gas, index=low.air_index, dx_cell=low.pipe_dx_cell,
                   dx_face=low.pipe_dx_face, leak=low.pipe_leak, cv=low.cv_rows,
                   dv=low.dv_rows, dv_cell=low.dv_cell)
    drive = Drive(of=low.drive_of, z=low.drive_z, motor=low.drive_motor,
                  ctrl=low.drive_ctrl, ws=low.drive_ws, rail=low.drive_rail,
                  slip=low.drive_slip, misc=low.drive_misc)
    return Train(veh=low.veh, powered=np.flatnonzero(low.veh[:, V_SHARE] > 0.0).astype(np.int64),
                 inv_m=1.0 / low.veh[:, V_MASS], cons=low.cons, trac=low.trac,
                 track_pos=low.track_pos, track_grade=low.track_grade,
                 track_curv=low.track_curv, curve_h=low.curve_h, tables=low.ctab, air=air,
                 drive=drive)


def make_couplers(low) -> Couplers:
    """:class:`Couplers` of a :class:`~ltdsim.engine.lowering.Lowered` scenario."""
    return Couplers(model=low.cpl_model, par=low.cpl, uniform=uniform_model(low.cpl_model))


def uniform_model(model: np.ndarray) -> int:
    """The model code that every coupler of ``model`` (int64 codes) has, or -1 when
    they differ or there is none (:class:`Couplers`' ``uniform``)."""
    if model.shape[0] == 0 or not (model == model[0]).all():
        return -1
    return int(model[0])


def make_driver(low) -> Driver:
    """:class:`Driver` of a :class:`~ltdsim.engine.lowering.Lowered` scenario."""
    return Driver(par=low.drv, prof_t=low.prof_t, prof_y=low.prof_y)


def make_controller(events: np.ndarray) -> Controller:
    """A controller that has done nothing yet, issuing its brake commands into
    ``events`` (``(max commands, N_EVENT_COLUMNS)``, ``EV_*`` columns, zeros: a
    command's kind is ``CMD_LEVEL`` unless it says otherwise)."""
    return Controller(state=np.zeros(1, dtype=CONTROLLER), pid=np.zeros(1, dtype=PID_STATE),
                      events=events)


def make_stepper(h0: float) -> np.ndarray:
    """bs23 state before the first step: first step ``h0`` (s), no steps taken."""
    st = np.zeros(1, dtype=STEPPER)
    st[0]["h"] = h0
    st[0]["last_error"] = 1.0
    return st


def make_work(n: int, ny: int, stages: int, n_consists: int, cells: int = 0,
              air_steps: bool = False, drives: int = 0, energy: bool = False,
              braked: bool = False) -> Work:
    """:class:`Work` for ``n`` vehicles, a state of ``ny`` elements, ``stages`` stage
    derivatives, ``n_consists`` locomotive consists and ``cells`` brake-pipe cells
    (fluid brake); ``air_steps``: the fluid brake's pneumatic states take their own
    steps (:func:`run_adaptive` with ``brake.model = "fluid"``); ``drives`` induction
    drives; ``energy``: the run accounts for the energy (``solver.energy``); ``braked``:
    some vehicle has an air brake."""
    nc = max(n - 1, 1)
    ne = N_ENERGY + n - 1 if energy else 0
    air_step = np.zeros(1, dtype=AIR_STEPPER)
    air_step[0]["h"] = 1e-4
    air_step[0]["last_error"] = 1.0
    return Work(K=np.zeros(stages * ny), ytmp=np.zeros(ny), ynew=np.zeros(ny),
                force=np.zeros(nc), defl=np.zeros(nc), res=np.zeros(n), bforce=np.zeros(n),
                fcons=np.zeros(n_consists), sig=np.zeros(1, dtype=SIGNALS),
                hints=np.zeros(n + 2 + n_consists, dtype=np.int64),
                tkey=np.full(n, -1, dtype=np.int64), tres=np.zeros((n, 2)),
                inflow=np.zeros(cells),
                air=np.zeros((N_AIR_ROWS, ny if air_steps else 0)), air_step=air_step,
                ddem=np.zeros(drives), dsig=np.zeros((drives, N_DRIVE_SIGNALS)),
                dout=np.zeros((drives, N_OUT)), energy=np.zeros(ne), pw=np.zeros((3, ne)),
                fprev=np.zeros(n_consists), bforce_on=np.array([braked]))


def work_size(n: int, ny: int, stages: int, n_consists: int = 1, cells: int = 0,
              air_steps: bool = False, drives: int = 0, energy: bool = False) -> int:
    """Elements (8 bytes each) of the :class:`Work` that :func:`make_work` builds for the
    same arguments, counted without allocating it (the memory check before a run)."""
    nc = max(n - 1, 1)
    return (stages * ny + 2 * ny + 2 * nc + 2 * n + n_consists + len(SIGNALS.names)
            + n + 2 + n_consists + 3 * n + cells + (N_AIR_ROWS * ny if air_steps else 0)
            + len(AIR_STEPPER.names) + drives * (1 + N_DRIVE_SIGNALS + N_OUT)
            + (4 * (N_ENERGY + n - 1) if energy else 0) + n_consists + 1)

@njit(cache=True, inline="always")
def _segment(xs, x, hint):
    """Index k of the segment ``xs[k] <= x < xs[k+1]`` (0 before the first point).

    Starts from the previous answer ``hint``, so a slowly moving argument costs O(1).
    The answer does not depend on the hint: it only speeds up the search.
    """
    k = hint
    m = xs.shape[0]
    while k + 1 < m and xs[k + 1] <= x:
        k += 1
    while k > 0 and xs[k] > x:
        k -= 1
    return k


@njit(cache=True, inline="always")
def _interp(xs, ys, x, hints, slot):
    """Linear interpolation of ``(xs, ys)`` at ``x``, constant beyond the ends."""
    k = _segment(xs, x, hints[slot])
    hints[slot] = k
    if x <= xs[0]:
        return ys[0]
    if k + 1 >= xs.shape[0]:
        return ys[k]
    w = (x - xs[k]) / (xs[k + 1] - xs[k])
    return ys[k] + w * (ys[k + 1] - ys[k])


@njit(cache=True, inline="always")
def _held(xs, ys, x, hints, slot):
    """Value of the step function ``(xs, ys)`` at ``x``: ``ys[k]`` from ``xs[k]`` on."""
    k = _segment(xs, x, hints[slot])
    hints[slot] = k
    return ys[k]


@njit(cache=True, inline="always")
def _held_at(tab, off, m, x):
    """Step function stored as ``m`` abscissae then ``m`` values from ``tab[off]``."""
    k = 0
    while k + 1 < m and tab[off + k + 1] <= x:
        k += 1
    return tab[off + m + k]


@njit(cache=True, inline="always")
def _interp_at(tab, off, m, x):
    """Linear interpolation of ``m`` points stored as abscissae then values from
    ``tab[off]``, constant beyond the ends."""
    if x <= tab[off]:
        return tab[off + m]
    k = 0
    while k + 1 < m and tab[off + k + 1] <= x:
        k += 1
    if k + 1 >= m:
        return tab[off + m + k]
    x0 = tab[off + k]
    w = (x - x0) / (tab[off + k + 1] - x0)
    return tab[off + m + k] + w * (tab[off + m + k + 1] - tab[off + m + k])


@njit(cache=True, inline="always")
def shoe_friction(i, v, shoe_force, veh, ctab):
    """Shoe-wheel friction coefficient of vehicle ``i``'s brake at speed ``v`` (m/s)
    and force per shoe ``shoe_force`` (N)."""
    model = int(veh[i, V_BFRIC])
    if model == FRICTION_KARWATZKI:
        return karwatzki_mu(v, shoe_force)
    if model == FRICTION_CONSTANT:
        return veh[i, V_BMU]
    return _interp_at(ctab, int(veh[i, V_BTAB]), int(veh[i, V_BNTAB]), abs(v))


@njit(cache=True, inline="always")
def brake_target(t, delay, events, n_events):
    """Brake level (0-1) that the latest command to have reached a vehicle with signal
    delay ``delay`` (s) asks for at time ``t`` (s); 0 before any command arrives."""
    e = n_events - 1
    while e >= 0:
        if events[e, EV_TIME] + delay <= t:
            return events[e, EV_LEVEL]
        e -= 1
    return 0.0


@njit(cache=True, _nrt=False, forceinline=True)
def _resistance(y, tr, w):
    """Running resistance of every vehicle (N, + opposing forward motion) at state ``y``:
    Davis terms at its speed, grade and curve resistance of the track segment under it.
    Writes ``w.res`` and the total to ``w.sig["resistance"]``; returns the total, N.

    A vehicle's grade force and curve resistance depend on its segment only (and on the
    sign of its speed): they are worked out when it enters a segment and kept in
    ``w.tres`` (the same numbers, computed once instead of at every evaluation)."""
    veh = tr.veh
    hints = w.hints
    tkey = w.tkey
    tres = w.tres
    res = w.res
    n = veh.shape[0]
    g = tr.trac[T_G]
    rtot = 0.0
    for i in range(n):
        v = y[n + i]
        p = veh[i, V_P0] + y[i]
        r = davis_force(v, veh[i, V_DA], veh[i, V_DB], veh[i, V_DC], veh[i, V_DIV0])
        kt = _segment(tr.track_pos, p, hints[i])
        hints[i] = kt
        if kt != tkey[i]:
            wm = veh[i, V_WMASS]
            tkey[i] = kt
            tres[i, 0] = grade_force(wm, tr.track_grade[kt], g)
            tres[i, 1] = curve_force(1.0, wm, tr.track_curv[kt], tr.curve_h, g)  # (> 0)
        r += tres[i, 0]
        c = tres[i, 1]
        r += c if v > 0.0 else (-c if v < 0.0 else 0.0)  # curve_force's sign rule
        rtot += r
        res[i] = r
    w.sig[0]["resistance"] = rtot
    return rtot


@njit(cache=True, _nrt=False, forceinline=True)
def _brakes(t, y, events, n_events, tr, dr, w, dy):
    """Air brakes at time ``t`` (s), every state in ``y``: the lumped brake
    (:func:`_lumped_brakes`) or the fluid brake with its pneumatic states advanced with
    the rest (:func:`_fluid_brakes`, the fixed-step kernel :func:`run`). Nothing when
    the train has no air brakes."""
    if dr.par[D_BMODEL] == BRAKE_FLUID:
        _fluid_brakes(t, y, events, n_events, tr, dr, w, dy)
    elif dr.par[D_BFULLSUM] > 0.0:
        _lumped_brakes(t, y, events, n_events, tr, dr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _brakes_split(t, y, events, n_events, tr, dr, w, dy):
    """Air brakes at time ``t`` (s) for :func:`run_adaptive`: the lumped brake
    (:func:`_lumped_brakes`) or the fluid brake's forces from its pneumatic states,
    which that kernel advances on their own steps (:func:`_fluid_forces`; ``y`` then
    holds the mechanical states only). Nothing when the train has no air brakes."""
    if dr.par[D_BMODEL] == BRAKE_FLUID:
        _fluid_forces(t, y, tr, dr, w)
    elif dr.par[D_BFULLSUM] > 0.0:
        _lumped_brakes(t, y, events, n_events, tr, dr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _lumped_brakes(t, y, events, n_events, tr, dr, w, dy):
    """The lumped air brake at time ``t`` (s): each brake-cylinder fill (0-1) follows
    the latest of the commands ``events[:n_events]`` to have reached its vehicle, with
    the apply or release time constant (s); its rate (1/s) goes to ``dy``. The shoe
    force (N) times the shoe friction gives the braking force, written to ``w.bforce``
    (N, + opposing forward motion) and added to ``w.res``."""
    drv = dr.par
    veh = tr.veh
    ctab = tr.tables
    res = w.res
    n = veh.shape[0]
    vs = drv[D_BVS]
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb < 0:
            continue
        v = y[n + i]
        target = brake_target(t, veh[i, V_BDELAY], events, n_events)
        fill = y[zb]
        tau = drv[D_BTAUA] if target > fill else drv[D_BTAUR]
        # (settled within 1e-12: an endless decay to 0 ends in slow subnormals)
        dy[zb] = (target - fill) / tau if abs(target - fill) > 1e-12 else 0.0
        fb = 0.0
        if fill > 0.0:
            shoe = fill * veh[i, V_BSHOE]
            fb = -retarding_force(v, fill * veh[i, V_BFULL]
                                    * shoe_friction(i, v, shoe, veh, ctab), vs)
        w.bforce[i] = fb
        res[i] += fb


@njit(cache=True, inline="always")
def fluid_command(t, events, n_events, full):
    """Handle (``brakevalves.H_*``) and service reduction (Pa) of the driver's valves at
    time ``t`` (s): the latest of ``events[:n_events]`` issued by then (every
    brake-control point at once: the remote units follow the lead by radio). A command
    by level L (``CMD_LEVEL``) is a service reduction of L x ``full`` (Pa), 0 a release;
    before any command, release (the pipe charged)."""
    e = n_events - 1
    while e >= 0:
        if events[e, EV_TIME] <= t:
            kind = events[e, EV_KIND]
            if kind == CMD_LEVEL:
                level = events[e, EV_LEVEL]
                if level > 0.0:
                    return H_SERVICE, level * full
                return H_RELEASE, 0.0
            if kind == CMD_RELEASE:
                return H_RELEASE, 0.0
            if kind == CMD_EMERGENCY:
                return H_EMERGENCY, 0.0
            return H_SERVICE, events[e, EV_VALUE]
        e -= 1
    return H_RELEASE, 0.0


@njit(cache=True, _nrt=False, forceinline=True)
def _air_rates(t, y, events, n_events, tr, w, dy):
    """The fluid-dynamic air brake's pneumatics at time ``t`` (s): the rates of the brake
    pipe's cell pressures (Pa/s) and face flows (kg/s^2)
    (:func:`~ltdsim.physics.air.brakepipe.pipe_rates`), of every driver's valve's and
    control valve's states (:func:`~ltdsim.physics.air.brakevalves.driver_valve`,
    ``control_valve``) and of the air exhausted to atmosphere (kg/s: vents, exhausts and
    leaks, less what compressors deliver), written to ``dy`` at the states' places in
    ``y`` (``tr.air.index``). The driver's valves all take the latest command
    (:func:`fluid_command`). Reads and writes the fluid brake's states only.

    Inlined by LLVM like the other subsystems, and so are the laws it calls (the pipe,
    the valves, the orifice law: ``forceinline``). Compiled once and called instead, the
    two kernels' first compile took as long (73 s of CPU against 66-71 s); the time went
    into numba's own inlining of the laws' bodies (``inline="always"``), and letting
    LLVM inline them instead cut the bs23 kernel's first compile from 45 to 33 s of CPU
    with the same results to the bit."""
    air = tr.air
    gas = air.gas
    idx = air.index
    veh = tr.veh
    inflow = w.inflow
    n = veh.shape[0]
    gamma = gas[A_GAMMA]
    r_gas = gas[A_RGAS]
    temp = gas[A_TEMP]
    atm = gas[A_ATM]
    r_lin = gas[A_RLIN]
    zp = idx[I_PIPE]
    nc = idx[I_CELLS]
    zq = zp + nc
    zd = idx[I_DV]
    zx = idx[I_EXH]
    p = y[zp:zq]
    for c in range(nc):
        inflow[c] = 0.0
    exhausted = 0.0
    handle, reduction = fluid_command(t, events, n_events, air.dv[0, DV_FULL])
    for c in range(idx[I_NCP]):
        o = zd + c * N_DV
        cell = air.dv_cell[c]
        into, out = driver_valve(p[cell], y[o:o + N_DV], air.dv[c], handle, reduction, gamma,
                                 r_gas, temp, atm, r_lin, dy[o:o + N_DV])
        inflow[cell] += into
        exhausted += out - driver_valve_compressor(y[o:o + N_DV], air.dv[c])
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb < 0:
            continue
        cell = int(veh[i, V_BCELL])
        draw, out = control_valve(p[cell], y[zb:zb + N_CV], air.cv[int(veh[i, V_BCV])], gamma,
                                  r_gas, temp, atm, r_lin, dy[zb:zb + N_CV])
        inflow[cell] -= draw
        exhausted += out
    leak = pipe_rates(p, y[zq:zq + nc - 1], inflow,
                      (gas[A_AREA], air.dx_cell, air.dx_face, gas[A_DIAM], gas[A_ROUGH],
                       gas[A_VISC], air.leak), (gamma, r_gas, temp, atm, r_lin),
                      dy[zp:zq], dy[zq:zq + nc - 1])
    dy[zx] = exhausted + leak


@njit(cache=True, _nrt=False, forceinline=True)
def _cylinder_brake(i, p_cyl, v, tr, vs, w):
    """Braking force of vehicle ``i`` at speed ``v`` (m/s) from its brake-cylinder
    pressure ``p_cyl`` (Pa gauge): ``max(0, p x piston area - return spring) x
    efficiency x rigging ratio`` on its shoes, times the shoe friction, through
    :func:`~ltdsim.physics.air.brakes.brake_retardation` (standstill speed ``vs``, m/s).
    Written to ``w.bforce`` (N, + opposing forward motion) and added to ``w.res``."""
    veh = tr.veh
    fc = max(p_cyl * veh[i, V_BAREA] - veh[i, V_BSPRING], 0.0) * veh[i, V_BGAIN]
    fb = 0.0
    if fc > 0.0:
        shoe = fc * veh[i, V_BINVSHOES]
        fb = -retarding_force(v, fc * shoe_friction(i, v, shoe, veh, tr.tables), vs)
    w.bforce[i] = fb
    w.res[i] += fb


@njit(cache=True, _nrt=False, forceinline=True)
def _fluid_brakes(t, y, events, n_events, tr, dr, w, dy):
    """The fluid-dynamic air brake at time ``t`` (s) with its pneumatic states in ``y``
    (the fixed-step kernel :func:`run`): their rates (:func:`_air_rates`) to ``dy``, and
    each braked vehicle's braking force from its cylinder pressure
    (:func:`_cylinder_brake`)."""
    _air_rates(t, y, events, n_events, tr, w, dy)
    veh = tr.veh
    n = veh.shape[0]
    vs = dr.par[D_BVS]
    atm = tr.air.gas[A_ATM]
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb >= 0:
            _cylinder_brake(i, y[zb + CV_CYL] - atm, y[n + i], tr, vs, w)


@njit(cache=True, _nrt=False, forceinline=True)
def _hermite_weights(t, st):
    """Rows of :class:`Work`'s ``air`` array holding ``y0, f0, y1, f1`` and weights
    ``(h00, h10 H, h01, h11 H)`` of the cubic Hermite interpolant at ``t`` (s) over the
    pneumatic step that holds ``t``: the current one ``[t0, t1]`` of the ``AIR_STEPPER``
    record ``st``, or the previous one ``[tp, t0]`` when ``t < t0`` and it is kept
    (``H`` the step's length). The value at ``t`` is ``h00 y0 + h10 H f0 + h01 y1 + h11
    H f1`` from the states ``y`` and rates ``f`` at both ends (the dense output of the
    bs23 pair, third order like its solution; weights of ``y0`` and ``y1`` sum to 1, so
    mass stays conserved). ``t`` is clipped to the step."""
    t0 = st["t0"]
    t1 = st["t1"]
    r0, r1, r2, r3 = AIR_Y0, AIR_F0, AIR_Y1, AIR_F1
    if t < t0 and st["tp"] < t0:
        t1 = t0
        t0 = st["tp"]
        r0, r1, r2, r3 = AIR_YP, AIR_FP, AIR_Y0, AIR_F0
    big_h = t1 - t0
    if big_h <= 0.0:
        return r0, r1, r2, r3, 1.0, 0.0, 0.0, 0.0
    th = min(max((t - t0) / big_h, 0.0), 1.0)
    u = 1.0 - th
    return (r0, r1, r2, r3, (1.0 + 2.0 * th) * u * u, th * u * u * big_h,
            th * th * (3.0 - 2.0 * th), -th * th * u * big_h)


@njit(cache=True, _nrt=False, forceinline=True)
def _fluid_forces(t, y, tr, dr, w):
    """The fluid-dynamic air brake's forces at time ``t`` (s) for :func:`run_adaptive`,
    whose pneumatic states move on their own steps (:func:`_air_step`): each braked
    vehicle's cylinder pressure interpolated in the pneumatic step that holds ``t``
    (:func:`_hermite_weights`), its braking force by :func:`_cylinder_brake` at its
    speed in ``y``."""
    veh = tr.veh
    n = veh.shape[0]
    vs = dr.par[D_BVS]
    atm = tr.air.gas[A_ATM]
    ab = w.air
    r0, r1, r2, r3, a0, a1, a2, a3 = _hermite_weights(t, w.air_step[0])
    for i in range(n):
        zb = int(veh[i, V_BZ])
        if zb >= 0:
            q = zb + CV_CYL
            pc = a0 * ab[r0, q] + a1 * ab[r1, q] + a2 * ab[r2, q] + a3 * ab[r3, q]
            _cylinder_brake(i, pc - atm, y[n + i], tr, vs, w)


@njit(cache=True, _nrt=False, forceinline=True)
def _air_interpolate(t, tr, w, y):
    """Every pneumatic state at ``t`` (s), interpolated in the pneumatic step that holds
    it (:func:`_hermite_weights`), written to its place in ``y`` (for the records)."""
    ab = w.air
    r0, r1, r2, r3, a0, a1, a2, a3 = _hermite_weights(t, w.air_step[0])
    for q in range(tr.air.index[I_PIPE], ab.shape[1]):
        y[q] = a0 * ab[r0, q] + a1 * ab[r1, q] + a2 * ab[r2, q] + a3 * ab[r3, q]


@njit(cache=True, _nrt=False, forceinline=True)
def _air_start(t, y, tr, w):
    """Start the pneumatic stepping at ``t`` (s) from the pneumatic states in ``y``: a
    step of length 0 at ``t`` (its rates follow from :func:`_air_cut`)."""
    ab = w.air
    st = w.air_step[0]
    for q in range(tr.air.index[I_PIPE], ab.shape[1]):
        ab[AIR_Y0, q] = y[q]
        ab[AIR_Y1, q] = y[q]
        ab[AIR_F0, q] = 0.0
        ab[AIR_F1, q] = 0.0
    st["t0"] = t
    st["t1"] = t
    st["tp"] = t
    st["started"] = True


@njit(cache=True, _nrt=False, forceinline=True)
def _air_cut(t, events, n_events, tr, w):
    """End the pneumatic stepping at ``t`` (s), inside the current pneumatic step or at
    its end, or inside the previous one (the next was taken ahead and is dropped),
    because a brake command was issued at ``t`` (or the stepping starts there,
    :func:`_air_start`): the states at ``t`` interpolated, their rates evaluated with the
    commands issued so far (at the start, the same rates at both ends)."""
    ab = w.air
    st = w.air_step[0]
    z0 = tr.air.index[I_PIPE]
    if t < st["t0"] and st["tp"] < st["t0"]:  # back to the previous step
        for q in range(z0, ab.shape[1]):
            ab[AIR_Y1, q] = ab[AIR_Y0, q]
            ab[AIR_F1, q] = ab[AIR_F0, q]
            ab[AIR_Y0, q] = ab[AIR_YP, q]
            ab[AIR_F0, q] = ab[AIR_FP, q]
        st["t1"] = st["t0"]
        st["t0"] = st["tp"]
    _air_interpolate(t, tr, w, ab[AIR_YT])
    for q in range(z0, ab.shape[1]):
        ab[AIR_Y1, q] = ab[AIR_YT, q]
    _air_rates(t, ab[AIR_Y1], events, n_events, tr, w, ab[AIR_F1])
    if st["t0"] == t:  # a step of length 0 (the start)
        for q in range(z0, ab.shape[1]):
            ab[AIR_Y0, q] = ab[AIR_Y1, q]
            ab[AIR_F0, q] = ab[AIR_F1, q]
    st["t1"] = t
    st["tp"] = st["t0"]  # the steps after t are to be taken anew


@njit(cache=True, _nrt=False, forceinline=True)
def _air_step(t_cap, events, n_events, tr, w, ad):
    """One accepted step of the fluid brake's pneumatic states, on their own from the
    end ``t1`` of the last one, for :func:`run_adaptive`: the bs23 pair of ``ad`` under
    the same error control as the mechanical states (``ad.atol``, ``ad.rtol`` of the
    pneumatic states, max norm, PI step control), at most ``ad.air_h_max`` long and ending
    no later than ``t_cap`` (s). The pneumatics do not depend on the mechanical states
    (only on the driver's commands), so they need not move in the mechanical steps,
    which take far smaller steps when gears and slack are at work: the mechanical right
    hand side reads the cylinder pressures from this step's interpolant
    (:func:`_fluid_forces`), and a command issued inside the step ends it there
    (:func:`_air_cut`). Returns False when no step down to 1e-12 s gives a finite state."""
    ab = w.air
    st = w.air_step[0]
    y0 = ab[AIR_Y0]
    y1 = ab[AIR_Y1]
    f0 = ab[AIR_F0]
    f1 = ab[AIR_F1]
    k2 = ab[AIR_K2]
    k3 = ab[AIR_K3]
    yt = ab[AIR_YT]
    z0 = tr.air.index[I_PIPE]
    ny = ab.shape[1]
    A = ad.A
    B = ad.b
    C = ad.c
    E = ad.e
    atol = ad.atol
    rtol = ad.rtol
    t = st["t1"]
    yp = ab[AIR_YP]
    fp = ab[AIR_FP]
    for q in range(z0, ny):  # the current step becomes the previous one
        yp[q] = y0[q]
        fp[q] = f0[q]
        y0[q] = y1[q]
        f0[q] = f1[q]
    st["tp"] = st["t0"]
    st["t0"] = t
    h = st["h"]
    while True:
        h_try = min(h, ad.air_h_max)
        hit = False
        if t + h_try >= t_cap:
            h_try = t_cap - t
            hit = True
        # stages 2 and 3, then the rates at the step's end (stage s reads the state
        # row src and writes the rates row dst; one call of the brake's law, so that it
        # is compiled once here)
        finite = True
        for stage in range(1, 4):
            if stage < 3:
                src = AIR_YT
                dst = AIR_K2 if stage == 1 else AIR_K3
                a0, a1 = h_try * A[stage, 0], h_try * A[stage, 1]
                if stage == 1:
                    for q in range(z0, ny):
                        yt[q] = y0[q] + a0 * f0[q]
                else:
                    for q in range(z0, ny):
                        yt[q] = y0[q] + a0 * f0[q] + a1 * k2[q]
                ts = t + C[stage] * h_try
            else:
                src = AIR_Y1
                dst = AIR_F1
                b0, b1, b2 = h_try * B[0], h_try * B[1], h_try * B[2]
                total = 0.0
                for q in range(z0, ny):
                    y1[q] = y0[q] + (b0 * f0[q] + b1 * k2[q] + b2 * k3[q])
                    total += y1[q]
                finite = total - total == 0.0
                if not finite:
                    break
                ts = t_cap if hit else t + h_try
            _air_rates(ts, ab[src], events, n_events, tr, w, ab[dst])
        t_new = t_cap if hit else t + h_try
        err = np.inf
        if finite:
            e0, e1, e2, e3 = h_try * E[0], h_try * E[1], h_try * E[2], h_try * E[3]
            err = 0.0
            for q in range(z0, ny):
                e = abs(e0 * f0[q] + e1 * k2[q] + e2 * k3[q] + e3 * f1[q]) \
                    / (atol[q] + rtol[q] * max(abs(y0[q]), abs(y1[q])))
                if e > err:
                    err = e
            if not (err - err == 0.0):
                err = np.inf
        if err <= 1.0:
            st["t1"] = t_new
            st["accepted"] += 1
            if err == 0.0:
                fac = 5.0
            else:
                fac = 0.9 * err ** (-0.7 / 3.0) * max(st["last_error"], 1e-4) ** (0.4 / 3.0)
                fac = min(5.0, max(0.2, fac))
            if st["last_rejected"]:
                fac = min(fac, 1.0)
            st["last_error"] = err
            st["last_rejected"] = False
            st["h"] = h_try * fac if (not hit or fac < 1.0) else max(h, h_try * fac)
            return True
        st["rejected"] += 1
        st["last_rejected"] = True
        h = h_try * (0.2 if err == np.inf else max(0.2, 0.9 * err ** (-1.0 / 3.0)))
        if h < 1e-12:
            for q in range(z0, ny):  # the step's start stays the state
                y1[q] = y0[q]
                f1[q] = f0[q]
            st["t1"] = t
            return False


@njit(cache=True, _nrt=False, forceinline=True)
def _traction(t, y, a_dem, rtot, tr, dr, w, dy):
    """Traction and dynamic-brake force of each locomotive consist (N, + forward) at
    time ``t`` (s), written to ``w.fcons``; the motor lags' rates (N/s) go to ``dy``.

    The driver's demand by mode: speed, the held demanded acceleration ``a_dem``
    (m/s^2) times the train's mass plus the feed-forward share of the total resistance
    ``rtot`` (N); force, the force profile (N); notch, the held notch (0-8) as a share
    of each consist's limit. A consist with its own notch schedule follows that. The
    demand is shared among the consists and clipped to each one's traction curve
    (force, power and adhesion limits, N). Writes the total applied force and the total
    demand before the limits (N) to ``w.sig``."""
    veh = tr.veh
    cons = tr.cons
    trac = tr.trac
    ctab = tr.tables
    drv = dr.par
    hints = w.hints
    n = veh.shape[0]
    g = trac[T_G]
    mode = drv[D_MODE]
    fd = 0.0
    if mode == MODE_SPEED:
        fd = a_dem * trac[T_MTOT] + trac[T_FF] * rtot
    elif mode == MODE_FORCE:
        fd = _interp(dr.prof_t, dr.prof_y, t, hints, n)
    else:
        fd = _held(dr.prof_t, dr.prof_y, t, hints, n) / 8.0  # notch fraction
    ftot = 0.0
    fdem = 0.0
    for c in range(cons.shape[0]):
        vc = y[n + int(cons[c, K_VEH])]
        lim = traction_max(vc, cons[c, K_FMAX], cons[c, K_PMAX], cons[c, K_MADH], g)
        m_own = int(cons[c, K_NLEN])
        if m_own > 0:
            dem = _held_at(ctab, int(cons[c, K_NOFF]), m_own, t) / 8.0 * lim
        elif mode == MODE_NOTCH:
            dem = fd * lim
        else:
            dem = fd * cons[c, K_SHARE]
        fdem += dem
        kd = tr.drive.of[c]
        if kd >= 0:  # an induction drive: _induction turns the demand into force
            w.ddem[kd] = dem
            continue
        dl = min(max(dem, -lim), lim)
        z = int(cons[c, K_Z])
        if z >= 0:  # motor and inverter lag, with the jerk limit on its rate
            f = y[z]
            # (settled within 1e-6 N: an endless decay ends in slow subnormals)
            rate = (dl - f) / cons[c, K_TAU] if abs(dl - f) > 1e-6 else 0.0
            rmax = cons[c, K_RATE]
            if rmax > 0.0:
                rate = min(max(rate, -rmax), rmax)
            dy[z] = rate
            f = min(max(f, -lim), lim)
        else:
            f = dl
        fade = cons[c, K_DBFADE]
        if f < 0.0 and fade > 0.0:  # dynamic braking dies away as the motors slow
            f *= min(max(vc / fade, 0.0), 1.0)
        w.fcons[c] = f
        ftot += f
    sig = w.sig[0]
    sig["traction"] = ftot
    sig["demand"] = fdem


@njit(cache=True, _nrt=False)
def _drive_axle(y, dy, d, kd, vc, dem, out, sg):
    """Induction drive ``kd`` of the :class:`Drive` ``d`` (a consist's motors, alike) at
    vehicle speed ``vc`` (m/s) under the consist's demand ``dem`` (N): the rates of its
    states at ``y[d.z[kd]:]`` into ``dy``, its drive outputs into ``out`` and its signals
    into ``sg``; returns the consist's creep force, N (law in :func:`_induction`). A
    compiled function of its own, called, not inlined: inlined into every copy of the
    right-hand side it made the kernels' first compile slower
    (docs/induction-drive-train.md)."""
    z = d.z[kd]
    motor = d.motor[kd]
    ctrl = d.ctrl[kd]
    ws = d.ws[kd]
    rail = d.rail[kd]
    slip = d.slip[kd]
    misc = d.misc[kd]
    zw = z + N_DRIVE
    r = ws[W_R]
    gr = ws[W_I]
    eta = misc[DM_GEAR_EFF]
    nm = misc[DM_MOTORS]
    fade = misc[DM_FADE]
    if dem < 0.0 and fade > 0.0:
        dem *= min(max(vc / fade, 0.0), 1.0)
    tw = dem * r / nm
    om = y[zw]
    if misc[DM_SLIP_ON] > 0.0:
        if tw >= 0.0:
            tw, rate = slip_control(y[zw + 1], tw, om, vc, r, slip)
        else:  # braking: the same law on the mirrored slip (wheel-slide protection)
            tw, rate = slip_control(y[zw + 1], -tw, -om, -vc, r, slip)
            tw = -tw
        dy[zw + 1] = rate
    else:
        dy[zw + 1] = 0.0
    t_ref = tw / (gr * eta) if tw >= 0.0 else tw * eta / gr
    wm = gr * om
    te = drive_rates(y[z:zw], wm, t_ref, misc[DM_VDC], motor, ctrl, dy[z:zw], out)
    tw_m = gr * eta * te if te * wm >= 0.0 else gr * te / eta
    dom, f = wheelset_rate(om, vc, tw_m, ws, rail)
    dy[zw] = dom
    sg[DS_TORQUE] = te
    sg[DS_SPEED] = wm
    sg[DS_CURRENT] = misc[DM_TO_RMS] * np.sqrt(out[O_ID] * out[O_ID] + out[O_IQ] * out[O_IQ])
    sg[DS_CREEP] = (om * r - vc) / max(abs(vc), ws[W_VREG])
    sg[DS_FORCE] = misc[DM_PER_LOCO] * f
    sg[DS_PDC] = misc[DM_PER_LOCO] * out[O_PDC]
    sg[DS_PSD] = y[z + S_PSD]
    sg[DS_PSQ] = y[z + S_PSQ]
    sg[DS_PRD] = y[z + S_PRD]
    sg[DS_PRQ] = y[z + S_PRQ]
    return nm * f


@njit(cache=True, _nrt=False, forceinline=True)
def _induction(y, tr, w, dy):
    """Force of each locomotive consist with the induction drive (N, + forward), written
    to ``w.fcons`` and added to the signals' total traction; the rates of its states to
    ``dy``; its signals to ``w.dsig`` (:data:`ltdsim.engine.layout.DRIVE_SIGNALS`).

    One motor, its controller, one wheelset and one slip controller stand for each of
    the consist's motors (they share its speed and demand). The consist's demand
    ``w.ddem`` (N, from :func:`_traction`; a braking demand faded below the fade speed as
    on the curve) becomes a wheel-torque demand ``dem r / motors`` (N m); the slip
    controller (:func:`ltdsim.physics.drive.creep.slip_control`; in braking the same law on
    the mirrored slip) may lower its magnitude; the motor's torque demand is it over
    ``G eta`` (motoring) or times ``eta / G`` (braking). The drive
    (:func:`ltdsim.physics.drive.foc.drive_rates`) gives the motor torque ``T_m`` at the shaft
    speed ``G omega``; the gear gives the wheelset ``G eta T_m`` (motoring) or ``G T_m /
    eta`` (braking: the gear's loss is then on the wheel's side); the wheelset
    (:func:`ltdsim.physics.drive.creep.wheelset_rate`) turns under it against the creep force,
    which pushes the consist ``motors`` times."""
    d = tr.drive
    if d.z.shape[0] == 0:
        return
    cons = tr.cons
    n = tr.veh.shape[0]
    ftot = 0.0
    for c in range(cons.shape[0]):
        kd = d.of[c]
        if kd < 0:
            continue
        vc = y[n + int(cons[c, K_VEH])]
        fc = _drive_axle(y, dy, d, kd, vc, w.ddem[kd], w.dout[kd], w.dsig[kd])
        w.fcons[c] = fc
        ftot += fc
    w.sig[0]["traction"] += ftot


@njit(cache=True, inline="always")
def _coupler(j, model, y, n, cpl, ctab, w, dy):
    """Force (N, + tension) and deflection (m, + draft) of coupler ``j`` of model code
    ``model`` into ``w.force[j]`` and ``w.defl[j]`` (see :func:`_couplers`)."""
    d = y[j] - y[j + 1] + cpl[j, P_D0]
    dd = y[n + j] - y[n + j + 1]
    w.force[j] = coupler_force(j, model, d, dd, y, 2 * n, dy, 2 * n, cpl, ctab)
    w.defl[j] = d


@njit(cache=True, _nrt=False, forceinline=True)
def _couplers(y, tr, cp, w, dy):
    """Force (N, + tension) and deflection (m, + draft) of every coupler at state
    ``y``, written to ``w.force`` and ``w.defl``; the hysteretic gears' state rates go
    to ``dy`` (:func:`coupler_force`).

    A train whose couplers all share the simplified model (``cp.uniform``) runs a loop
    of its own, in which the compiler knows the model and drops the dispatch; the
    arithmetic is the same."""
    cpl = cp.par
    ctab = tr.tables
    n = tr.veh.shape[0]
    u = cp.uniform
    if u == M_SIMPLIFIED:
        for j in range(n - 1):
            _coupler(j, u, y, n, cpl, ctab, w, dy)
    else:
        for j in range(n - 1):
            _coupler(j, cp.model[j], y, n, cpl, ctab, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _force_balance(y, tr, w, dy):
    """Newton's second law for every vehicle: its share of its consist's force, minus
    its resistance and brake force, plus the coupler forces from its neighbours (all N)
    over its mass gives its acceleration (m/s^2), written to ``dy[n:2n]``; its speed
    (m/s) is its displacement's rate, ``dy[0:n]``."""
    veh = tr.veh
    inv_m = tr.inv_m
    fcons = w.fcons
    res = w.res
    force = w.force
    n = veh.shape[0]
    for i in range(n):
        # (an unpowered vehicle has share 0 and reads consist 0: no branch in the loop)
        f = veh[i, V_SHARE] * fcons[int(veh[i, V_CONS])] - res[i]
        if i < n - 1:
            f -= force[i]
        if i > 0:
            f += force[i - 1]
        dy[i] = y[n + i]
        dy[n + i] = f * inv_m[i]


@njit(cache=True, _nrt=False, forceinline=True)
def _powers(y, tr, w, row):
    """The power of each force on the train (W) at state ``y`` into ``w.pw[row]`` (the
    energy terms ``E_*``, then one per coupler), from the forces the last
    right-hand-side evaluation left in :class:`Work`: traction at the rail split into
    motoring and dynamic braking (:func:`_traction_powers`); air brakes, Davis, grade
    and curve resistance each the power it takes from the train (the grade's is the
    rate of potential energy gained, < 0 downhill; the Davis term is the vehicles' whole
    resistance less the other three, the forces the motion used); each coupler the power
    it takes, ``T (v_j - v_(j+1))`` (its gears' dissipation plus the rate of what they
    store)."""
    veh = tr.veh
    n = veh.shape[0]
    tres = w.tres
    res = w.res
    pw = w.pw
    pw[row, E_MOTOR], pw[row, E_DYN] = _traction_powers(y, tr, w, w.fcons)
    total = 0.0
    grade = 0.0
    curve = 0.0
    for i in range(n):
        v = y[n + i]
        total += res[i] * v
        grade += tres[i, 0] * v
        curve += tres[i, 1] * abs(v)  # (curve_force's sign rule: it opposes the motion)
    air = 0.0
    if w.bforce_on[0]:
        bforce = w.bforce
        for i in range(n):
            air += bforce[i] * y[n + i]
    pw[row, E_AIR] = air
    pw[row, E_DAVIS] = total - grade - curve - air
    pw[row, E_GRADE] = grade
    pw[row, E_CURVE] = curve
    force = w.force
    for j in range(n - 1):
        pw[row, N_ENERGY + j] = force[j] * (y[n + j] - y[n + j + 1])


@njit(cache=True, _nrt=False, forceinline=True)
def _traction_powers(y, tr, w, f_trac):
    """Power of the traction force ``f_trac`` (N per locomotive consist) at the rail at
    state ``y``, W: ``(motoring, dynamic braking)``, split by the sign of its power on
    each powered vehicle (dynamic braking counted as the power the locomotive takes
    back, >= 0)."""
    veh = tr.veh
    n = veh.shape[0]
    motor = 0.0
    dyn = 0.0
    for i in tr.powered:
        p = veh[i, V_SHARE] * f_trac[int(veh[i, V_CONS])] * y[n + i]
        if p > 0.0:
            motor += p
        else:
            dyn -= p
    return motor, dyn


@njit(cache=True, _nrt=False, forceinline=True)
def _account_fixed(first, h, y, tr, w):
    """The energy accounting of :func:`run` at the start of a step, after the right-hand
    side at ``(t, y)`` (so the forces in :class:`Work` are this state's).

    On a fixed grid the trapezoids of a power over the steps sum to ``h (the sum of all
    its samples - (first + latest) / 2)``, so each step only adds the powers now to their
    running sums (``w.pw[PW_SUM]``; the first samples in ``w.pw[PW_START]``) and
    :func:`_energy_totals` forms the totals where they are recorded. Traction is the
    exception: the driver's demand is held over a step and jumps where the controller
    samples, so each step's trapezoid takes its end with the force held over that step
    (``w.fprev``) and is added here."""
    pw = w.pw
    e = w.energy
    veh = tr.veh
    n = veh.shape[0]
    tres = w.tres
    res = w.res
    motor, dyn = _traction_powers(y, tr, w, w.fcons)
    if not first:
        held_m, held_d = _traction_powers(y, tr, w, w.fprev)
        half = 0.5 * h
        e[E_MOTOR] += half * (pw[PW_START, E_MOTOR] + held_m)
        e[E_DYN] += half * (pw[PW_START, E_DYN] + held_d)
    pw[PW_START, E_MOTOR] = motor
    pw[PW_START, E_DYN] = dyn
    for c in range(w.fcons.shape[0]):
        w.fprev[c] = w.fcons[c]
    # (branch-free loops over the vehicles and the couplers)
    total = 0.0
    grade = 0.0
    curve = 0.0
    for i in range(n):
        v = y[n + i]
        total += res[i] * v
        grade += tres[i, 0] * v
        curve += tres[i, 1] * abs(v)  # (curve_force's sign rule: it opposes the motion)
    air = 0.0
    if w.bforce_on[0]:
        bforce = w.bforce
        for i in range(n):
            air += bforce[i] * y[n + i]
    force = w.force
    if first:
        pw[PW_START, E_AIR] = air
        pw[PW_START, E_DAVIS] = total - grade - curve - air
        pw[PW_START, E_GRADE] = grade
        pw[PW_START, E_CURVE] = curve
        for j in range(n - 1):
            pw[PW_START, N_ENERGY + j] = force[j] * (y[n + j] - y[n + j + 1])
        for q in range(E_AIR, pw.shape[1]):
            pw[PW_SUM, q] = pw[PW_START, q]
        return
    pw[PW_SUM, E_AIR] += air
    pw[PW_SUM, E_DAVIS] += total - grade - curve - air
    pw[PW_SUM, E_GRADE] += grade
    pw[PW_SUM, E_CURVE] += curve
    for j in range(n - 1):
        pw[PW_SUM, N_ENERGY + j] += force[j] * (y[n + j] - y[n + j + 1])


@njit(cache=True, _nrt=False, forceinline=True)
def _energy_totals(h, y, tr, w):
    """The energy totals of :func:`run` at the state ``y`` just accounted
    (:func:`_account_fixed`) into ``w.energy`` (J): each continuous power's running sum
    over the grid of step ``h`` (s) less half its first and its latest sample (this
    state's, evaluated again here), times ``h`` (the trapezoids' sum); the traction
    terms are summed step by step."""
    pw = w.pw
    _powers(y, tr, w, PW_END)
    for q in range(E_AIR, pw.shape[1]):  # (E_MOTOR, E_DYN first: layout.ENERGY_TERMS)
        w.energy[q] = h * (pw[PW_SUM, q] - 0.5 * (pw[PW_START, q] + pw[PW_END, q]))


@njit(cache=True, _nrt=False, forceinline=True)
def _energy_rates(y, tr, w, dy):
    """For :func:`run_adaptive`: the powers (:func:`_powers`, W) as the rates of the
    energy states at ``y[ez:]`` (the trac slot ``T_EZ``; nothing when it is -1), which
    the embedded pair integrates with the motion, stage by stage: its steps are long,
    and a coupler's impact inside one is seen only by its stages."""
    ez = int(tr.trac[T_EZ])
    if ez < 0:
        return
    _powers(y, tr, w, PW_START)
    pw = w.pw
    for q in range(pw.shape[1]):
        dy[ez + q] = pw[PW_START, q]


@njit(cache=True, _nrt=False, forceinline=True)
def rhs(t, y, a_dem, n_events, tr, cp, dr, events, w, dy):
    """Right-hand side ``dy/dt`` at ``(t, y)``, written to ``dy`` (``len(y)`` elements):
    resistance, brakes, traction, couplers, force balance, in that order.

    ``tr``, ``cp``, ``dr``: :class:`Train`, :class:`Couplers`, :class:`Driver`;
    ``a_dem`` the demanded acceleration held by the speed controller (m/s^2);
    ``events[:n_events]`` the brake commands issued so far. Also fills, in the
    :class:`Work` ``w``: ``force``/``defl`` (coupler force N, deflection m), ``res``
    (resistance per vehicle, N), ``bforce`` (air-brake force per vehicle, N, + opposing
    forward motion), ``fcons`` (force of each locomotive consist, N) and the signals
    ``sig`` (total traction force N, traction demand before the traction-curve limits
    N, total resistance N). ``w.hints`` holds search cursors (``[0, n)`` track, ``n``
    driver profile, ``n + 1`` speed profile); they change only how fast a lookup is,
    never its result.
    """
    rtot = _resistance(y, tr, w)
    _brakes(t, y, events, n_events, tr, dr, w, dy)
    _traction(t, y, a_dem, rtot, tr, dr, w, dy)
    _induction(y, tr, w, dy)
    _couplers(y, tr, cp, w, dy)
    _force_balance(y, tr, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def rhs_split(t, y, a_dem, n_events, tr, cp, dr, events, w, dy):
    """:func:`rhs` for :func:`run_adaptive`, which advances the fluid brake's pneumatic
    states on their own steps: with ``brake.model = "fluid"``, ``y`` and ``dy`` hold
    the mechanical states only (those before ``tr.air.index[I_PIPE]``) and the brakes
    read the pneumatic step's interpolant (:func:`_brakes_split`). Otherwise the same
    as :func:`rhs`, operation for operation."""
    rtot = _resistance(y, tr, w)
    _brakes_split(t, y, events, n_events, tr, dr, w, dy)
    _traction(t, y, a_dem, rtot, tr, dr, w, dy)
    _induction(y, tr, w, dy)
    _couplers(y, tr, cp, w, dy)
    _force_balance(y, tr, w, dy)
    _energy_rates(y, tr, w, dy)


@njit(cache=True, inline="always")
def _push_event(ctl, t, level):
    """Append brake command ``(t, level)`` to the :class:`Controller` ``ctl``; False
    when its event store is full."""
    st = ctl.state[0]
    events = ctl.events
    m = st["n_events"]
    if m >= events.shape[0]:
        return False
    events[m, EV_TIME] = t
    events[m, EV_LEVEL] = level
    st["n_events"] = m + 1
    st["level"] = level
    return True


@njit(cache=True, inline="always")
def _push_command(ctl, t, tab, o, m, k):
    """Append scheduled brake command ``k`` of the ``m`` stored from ``tab[o]`` (one
    column after the other, :data:`ltdsim.engine.layout.EVENT_COLUMNS`) at time ``t`` (s);
    False when the event store is full."""
    if not _push_event(ctl, t, tab[o + m + k]):
        return False
    e = ctl.state[0]["n_events"] - 1
    ctl.events[e, EV_KIND] = tab[o + 2 * m + k]
    ctl.events[e, EV_VALUE] = tab[o + 3 * m + k]
    return True


@njit(cache=True, _nrt=False, forceinline=True)
def _brake_commands(t, horizon, y, ctl, tr, dr, w, sampled):
    """Issue the brake commands due at the start of a step at ``t`` (s).

    Scheduled applications with times before ``t + horizon`` are issued at their own
    times; a position trigger when the lead vehicle has passed it; a controller-made
    application (at controller samples, ``sampled``) when the demanded braking force
    exceeds the dynamic brake. Returns -1 if the event store overflowed, else the
    number of commands issued.
    """
    st = ctl.state[0]
    drv = dr.par
    ctab = tr.tables
    veh = tr.veh
    issued = 0
    m = int(drv[D_BSLEN])
    if m > 0:
        o = int(drv[D_BSOFF])
        k = st["next_scheduled"]
        while k < m and ctab[o + k] < t + horizon:
            if not _push_command(ctl, ctab[o + k], ctab, o, m, k):
                return -1
            issued += 1
            k += 1
        st["next_scheduled"] = k
    m = int(drv[D_BPLEN])
    if m > 0:
        o = int(drv[D_BPOFF])
        k = st["next_position"]
        lead = veh[0, V_P0] + y[0]
        while k < m and ctab[o + k] <= lead:
            if not _push_command(ctl, t, ctab, o, m, k):
                return -1
            issued += 1
            k += 1
        st["next_position"] = k
    if sampled and drv[D_BCTRL] > 0.0:
        cons = tr.cons
        trac = tr.trac
        n = veh.shape[0]
        g = trac[T_G]
        # braking force still wanted after the dynamic brake of every consist
        want = -(st["a_dem"] * trac[T_MTOT] + trac[T_FF] * w.sig[0]["resistance"])
        for c in range(cons.shape[0]):
            vc = y[n + int(cons[c, K_VEH])]
            lim = traction_max(vc, cons[c, K_FMAX], cons[c, K_PMAX], cons[c, K_MADH], g)
            fade = cons[c, K_DBFADE]
            if fade > 0.0:
                lim *= min(max(vc / fade, 0.0), 1.0)
            want -= lim
        level = 0.0
        if want > 0.0:
            v = y[n + int(trac[T_REF])]
            cap = drv[D_BFULLSUM] * expected_shoe_friction(v, drv, veh, ctab)
            level = min(want / cap, 1.0) if cap > 0.0 else 1.0
        step = drv[D_BSTEP]
        q = min(round(level / step) * step, 1.0)
        if q != st["level"]:
            if not _push_event(ctl, t, q):
                return -1
            issued += 1
    return issued


@njit(cache=True, inline="always")
def expected_shoe_friction(v, drv, veh, ctab):
    """Friction coefficient the controller expects at speed ``v`` (m/s): that of the
    first braked vehicle's shoes at the mean full shoe force."""
    for i in range(veh.shape[0]):
        if veh[i, V_BZ] >= 0:
            return shoe_friction(i, v, drv[D_BSHOEREF], veh, ctab)
    return 0.0


@njit(cache=True, inline="always")
def _fold_peak(peaks, j, f, t):
    """Fold force ``f`` (N) of coupler ``j`` at time ``t`` (s) into row j of the peak
    table (``PK_*`` columns)."""
    if f > peaks[j, PK_MAX]:
        peaks[j, PK_MAX] = f
        peaks[j, PK_TMAX] = t
    if f < peaks[j, PK_MIN]:
        peaks[j, PK_MIN] = f
        peaks[j, PK_TMIN] = t


@njit(cache=True, inline="always")
def _track_peaks(force, peaks, nc, t):
    """:func:`_fold_peak` for every coupler."""
    for j in range(nc):
        _fold_peak(peaks, j, force[j], t)


@njit(cache=True, inline="always")
def _sample_due(t, st, ts, tol):
    """The controller's clock, the same for both kernels: True when its next sample,
    at ``st["next_sample"] * ts`` (s), is due at ``t`` (s) within ``tol`` (s), and the
    clock then moves on to the sample after it."""
    m = st["next_sample"]
    if t >= m * ts - tol:
        st["next_sample"] = m + 1
        return True
    return False


@njit(cache=True, _nrt=False, forceinline=True)
def _stages(f, p, t, y, h, A, C, ns, K, ytmp):
    """Stages 2 to ``ns`` of an explicit Runge-Kutta step of size ``h`` (s) from
    ``(t, y)`` of the right-hand side ``f(t, y, dy, p)`` (a compiled function writing
    ``dy/dt`` to ``dy``; ``p`` its other arguments, one tuple), given stage 1 at
    ``K[0:ny]``: stage s is ``f`` at ``t + C[s] h`` and ``y + h sum_j A[s, j] K_j``,
    written to ``K[s * ny:(s + 1) * ny]``; ``ytmp`` (``ny`` elements) holds the stage
    state. The one stage routine of :func:`run`, :func:`run_adaptive` and the gear rig
    (:mod:`ltdsim.analysis.gears`)."""
    ny = y.shape[0]
    for s in range(1, ns):
        # (loops over the state innermost, one pass per nonzero coefficient: vectorised)
        first = True
        for j in range(s):
            wt = h * A[s, j]
            if wt != 0.0:
                o = j * ny
                if first:
                    for q in range(ny):
                        ytmp[q] = y[q] + wt * K[o + q]
                    first = False
                else:
                    for q in range(ny):
                        ytmp[q] += wt * K[o + q]
        if first:
            for q in range(ny):
                ytmp[q] = y[q]
        f(t + C[s] * h, ytmp, K[s * ny:(s + 1) * ny], p)


@njit(cache=True, inline="always")
def _advance(y, h, B, ns, K, inc):
    """End of a Runge-Kutta step of size ``h`` (s): ``y += h sum_s B[s] K_s`` over the
    ``ns`` stages at ``K[s * ny:(s + 1) * ny]``, the increment summed first (from 0, in
    stage order) for accuracy. The step's end for :func:`run` and the gear rig.

    Three and four stages (ode3, rk4) are written out, one pass over the state; other
    methods sum in ``inc`` (``ny`` elements), a pass per stage. Both forms add the same
    terms in the same order (the leading ``0.0 +`` included), so the result does not
    depend on the form."""
    ny = y.shape[0]
    if ns == 3:
        w0, w1, w2 = h * B[0], h * B[1], h * B[2]
        for q in range(ny):
            y[q] += ((0.0 + w0 * K[q]) + w1 * K[ny + q]) + w2 * K[2 * ny + q]
        return
    if ns == 4:
        w0, w1, w2, w3 = h * B[0], h * B[1], h * B[2], h * B[3]
        for q in range(ny):
            y[q] += (((0.0 + w0 * K[q]) + w1 * K[ny + q]) + w2 * K[2 * ny + q]) \
                + w3 * K[3 * ny + q]
        return
    for q in range(ny):
        inc[q] = 0.0
    for s in range(ns):
        wt = h * B[s]
        o = s * ny
        for q in range(ny):
            inc[q] += wt * K[o + q]
    for q in range(ny):
        y[q] += inc[q]


@njit(cache=True, inline="always")
def _finite(y):
    """True when every element of ``y`` is finite (their sum is; a sum overflowing to
    inf counts as not finite). A state that is not finite stays so: every later step
    adds to it, so checking now and then finds it at the next check."""
    total = 0.0
    for q in range(y.shape[0]):
        total += y[q]
    return total - total == 0.0


@njit(cache=True, _nrt=False, forceinline=True)
def _train_rhs(t, y, dy, p):
    """:func:`rhs` in the form :func:`_stages` calls: ``p = (a_dem, n_events, tr, cp,
    dr, events, w)``, its arguments after ``y``."""
    a_dem, n_events, tr, cp, dr, events, w = p
    rhs(t, y, a_dem, n_events, tr, cp, dr, events, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _train_rhs_split(t, y, dy, p):
    """:func:`rhs_split` in the form :func:`_stages` calls (as :func:`_train_rhs`)."""
    a_dem, n_events, tr, cp, dr, events, w = p
    rhs_split(t, y, a_dem, n_events, tr, cp, dr, events, w, dy)


@njit(cache=True, _nrt=False, forceinline=True)
def _controller(t, y, ctl, tr, dr, w):
    """One controller sample at ``t``: the PID's demanded acceleration, clipped to the
    acceleration limits. With anti-windup the integrator holds (conditional
    integration) while the demand is clipped, or the traction drives are at their
    limits (``w.sig``: applied and demanded force of the last evaluation), in the
    direction the error pushes."""
    drv = dr.par
    trac = tr.trac
    n = tr.veh.shape[0]
    st = ctl.state[0]
    pid = ctl.pid[0]
    ts = drv[D_TS]
    vref = _interp(dr.prof_t, dr.prof_y, t, w.hints, n + 1)
    e = vref - y[n + int(trac[T_REF])]
    u = pid_step(e, pid, drv[D_KP], drv[D_KI], drv[D_KD], drv[D_N], ts, int(drv[D_INT]),
                 int(drv[D_FILT]))
    uc = min(max(u, -trac[T_DMAX]), trac[T_AMAX])
    if drv[D_AW] > 0.0:
        sig = w.sig[0]
        clipped = (u - uc) * e > 0.0
        saturated = (abs(sig["demand"]) > abs(sig["traction"]) * (1.0 + 1e-9)
                     and sig["demand"] * e > 0.0)
        if clipped or saturated:
            pid["integrator"] -= ts * e
    st["a_dem"] = uc
    st["v_ref"] = vref


@njit(cache=True, _nrt=False)
def run(y, ctl, k_start, k_stop, fs, tr, cp, dr, w, out):
    """Advance ``y`` from step ``k_start`` to ``k_stop`` (time ``k dt``), recording.

    ``ctl`` :class:`Controller`, ``fs`` :class:`FixedStep`, ``tr`` :class:`Train`,
    ``cp`` :class:`Couplers`, ``dr`` :class:`Driver`, ``w`` :class:`Work` (its arrays
    sized by :func:`make_work` with ``fs``'s stages), ``out`` :class:`Outputs`.
    Records the state at every step that is a multiple of ``fs.record_every`` (record
    ``k // record_every``) and, when ``k_stop == fs.n_steps``, the final state. ``y``
    and ``ctl`` are updated in place so a run can be split into chunks; ``out.peaks``
    holds the peak coupler forces over every step.

    Returns ``(status, k)``: ``OK`` and ``k_stop``; ``NONFINITE`` and the first
    checked step whose state is not finite (``y`` then holds that state; the state is
    checked at every record step and at ``k_stop``, so it became non-finite after the
    last record step before ``k``); ``EVENTS_FULL`` and the step.
    """
    A = fs.A
    B = fs.b
    C = fs.c
    dt = fs.dt
    record_every = fs.record_every
    drv = dr.par
    st = ctl.state[0]
    K = w.K
    ytmp = w.ytmp
    force = w.force
    peaks = out.peaks
    n = tr.veh.shape[0]
    ny = y.shape[0]
    ns = B.shape[0]
    speed_mode = drv[D_MODE] == MODE_SPEED
    ts = drv[D_TS]
    half = 0.5 * dt  # (sample times fall on steps: ts is a whole number of steps)
    braking = (drv[D_BSLEN] + drv[D_BPLEN] + drv[D_BCTRL]) > 0.0
    energy = w.energy.shape[0] > 0
    # a counter instead of k % record_every: integer division is slow in the loop
    c_rec = k_start % record_every
    for k in range(k_start, k_stop):
        t = k * dt
        # non-finite values persist, so the state is checked only where it is recorded
        # (and at the chunk's end), not after every step
        if c_rec == 0 and not _finite(y):
            return NONFINITE, k
        sampled = speed_mode and _sample_due(t, st, ts, half)
        if sampled:
            _controller(t, y, ctl, tr, dr, w)
        if braking:
            if _brake_commands(t, dt, y, ctl, tr, dr, w, sampled) < 0:
                return EVENTS_FULL, k
        a_dem = st["a_dem"]
        n_ev = st["n_events"]
        # stage 1 is the right-hand side at (t_k, y_k): record it when due
        rhs(t, y, a_dem, n_ev, tr, cp, dr, ctl.events, w, K[0:ny])
        _track_peaks(force, peaks, n - 1, t)
        if energy:  # the work of the step that ended here, from the powers at its ends
            _account_fixed(k == 0, dt, y, tr, w)
        if c_rec == 0:
            if energy:
                _energy_totals(dt, y, tr, w)
            _record(k // record_every, t, y, K, a_dem, st["level"], speed_mode, tr, dr, w,
                    out)
        _stages(_train_rhs, (a_dem, n_ev, tr, cp, dr, ctl.events, w), t, y, dt, A, C, ns, K,
                ytmp)
        _advance(y, dt, B, ns, K, ytmp)
        c_rec += 1
        if c_rec == record_every:
            c_rec = 0
    if not _finite(y):
        return NONFINITE, k_stop
    if k_stop == fs.n_steps:
        t = k_stop * dt
        rhs(t, y, st["a_dem"], st["n_events"], tr, cp, dr, ctl.events, w, K[0:ny])
        _track_peaks(force, peaks, n - 1, t)
        if energy:
            _account_fixed(k_stop == 0, dt, y, tr, w)
            _energy_totals(dt, y, tr, w)
        _record(k_stop // record_every, t, y, K, st["a_dem"], st["level"], speed_mode, tr,
                dr, w, out)
    return OK, k_stop


@njit(cache=True, inline="always")
def _exerted_error(f1, e, f, f0):
    """Error estimate (N) of the force a hysteretic gear exerts, from the estimate ``e``
    (N, the kept solution minus the embedded one) of its internal force ``f1`` (N) at the
    step's end, where the gear exerts ``f`` (N, a magnitude); ``f0`` (N) its released
    force.

    The gear exerts ``f1`` clipped to its band between the unloading and the loading
    curve. Above the loading curve (``f1 > f``) the internal force runs ahead of the
    force by the gear's relaxation lag, and its error changes the force only as far as
    the embedded solution ``f1 - e`` falls below the curve; below the unloading curve
    likewise; locked in the band (``f1 == f``) the error is ``e`` itself. In the slack
    (``f == 0``) the internal force relaxes to ``f0`` and sets the force the gear meets
    the next load with, ``f1`` clipped to the band at closure, whose top is ``f0``
    (the released gear's loading curve): what counts is the error of ``min(f1, f0)``."""
    f_lo = f1 - e
    if f > 0.0:
        if f1 > f:
            return max(f - f_lo, 0.0)
        if f1 < f:
            return max(f_lo - f, 0.0)
        return abs(e)
    return abs(min(f1, f0) - min(f_lo, f0))


@njit(cache=True, inline="always")
def _in_slack(d, slack):
    """Is a coupling of free play ``slack`` (m) at deflection ``d`` (m) in its slack
    (as :func:`ltdsim.physics.gears.couplers.gear_deflection` decides)?"""
    return slack > 0.0 and abs(d) <= 0.5 * slack


@njit(cache=True, inline="always")
def _slack_throughout(j, y, ynew, K, ny, w10, w20, w21, cpl):
    """Was coupler ``j`` in its slack at the start of a step of the three-stage pair
    from ``y``, at its stages 2 and 3 (positions ``y + h sum A K``; ``w10 = h A[1, 0]``,
    ``w20 = h A[2, 0]``, ``w21 = h A[2, 1]``, s) and at its end ``ynew``? (Positions
    are the first states of ``y``, m; each stage position is summed as
    :func:`_stages` sums it.)"""
    slack = cpl[j, P_SLACK]
    d0 = cpl[j, P_D0]
    if not (_in_slack(y[j] - y[j + 1] + d0, slack)
            and _in_slack(ynew[j] - ynew[j + 1] + d0, slack)):
        return False
    a = y[j] + w10 * K[j]
    b = y[j + 1] + w10 * K[j + 1]
    if not _in_slack(a - b + d0, slack):
        return False
    a = y[j] + w20 * K[j] + w21 * K[ny + j]
    b = y[j + 1] + w20 * K[j + 1] + w21 * K[ny + j + 1]
    return _in_slack(a - b + d0, slack)


@njit(cache=True, inline="always")
def _relax_in_slack(j, q, qp, y, ynew, dyend, decay, cpl):
    """Relax the states of hysteretic gear ``j`` exactly over a step spent in its
    slack, from ``y`` into ``ynew``, and their rates at the step's end into ``dyend``
    (the first-same-as-last stage): its internal force (state ``q``, N) to the released
    force, its plates (state ``qp``, m; -1 none) home, each at the gear's relaxation
    rate (1/s), as :func:`ltdsim.engine.couplers.coupler_force` gives them in the slack
    (the plates stop within 1e-12 m of home, as there). ``decay`` is ``exp(-rate h)``
    for the step's size ``h`` (s)."""
    rate = cpl[j, P_RATE]
    f0 = cpl[j, P_F0]
    ynew[q] = f0 + (y[q] - f0) * decay
    dyend[q] = relax(ynew[q], f0, rate)
    if qp >= 0:
        p = y[qp]
        if p > 1e-12:
            p = max(p * decay, 1e-12)
        ynew[qp] = p
        dyend[qp] = plate_rate(-cpl[j, W_GAP], p, 0.0, cpl[j, W_BACK], rate) \
            if p > 1e-12 else 0.0


@njit(cache=True, _nrt=False)
def run_adaptive(y, ctl, stepper, r_start, r_stop, ad, tr, cp, dr, w, out):
    """Advance ``y`` with an embedded Runge-Kutta pair (the Bogacki-Shampine 3(2) of
    ``ad``) under error control, from record ``r_start`` (time ``r_start * ad.out_dt``)
    to record ``r_stop``.

    ``ctl`` :class:`Controller`, ``stepper`` one ``STEPPER`` record (array of one)
    carried over between calls, ``ad`` :class:`Adaptive`; the others as in :func:`run`
    (``w`` sized for the pair's stages plus one). Every step keeps the error estimate
    ``|y3 - y2|`` within ``atol + rtol |y|`` element by element (max norm), a
    hysteretic gear's internal force by the error of the force it exerts
    (:func:`_exerted_error`); a gear that spends the whole step in its slack has its
    states relaxed exactly (:func:`_relax_in_slack`). Steps end
    exactly on record times, controller samples and scheduled brake commands. Records
    ``r_start`` (when it is 0) to ``r_stop - 1``, and ``n_rec - 1`` when ``r_stop``
    reaches ``n_rec``.

    With the fluid brake (``w.air`` sized, see :func:`make_work`) the pneumatic states
    take their own steps under the same error control (:func:`_air_step`), as long as
    their dynamics allow, one step ahead when a mechanical step would pass the end of
    the current one: a mechanical step may span two pneumatic steps (it ends no later
    than the second), reads the cylinder pressures from the interpolant of the one that
    holds each stage's time (:func:`rhs_split`), and steps and controls the error of the
    mechanical states only. The pneumatic states in
    ``y`` are brought up to date at every record.

    Returns ``(status, t)``: ``OK``; ``NONFINITE`` when no step size down to 1e-12 s
    gives a finite state (``y`` holds the last good state at ``t``); ``EVENTS_FULL``.
    """
    drv = dr.par
    st = ctl.state[0]
    sp = stepper[0]
    A = ad.A
    B = ad.b
    C = ad.c
    E = ad.e
    ns = B.shape[0]
    atol = ad.atol
    err_atol = ad.err_atol
    gear_f1 = ad.gear_f1
    gear_of = ad.gear_of
    gear_plate = ad.gear_plate
    gear_exact = ad.gear_exact
    cpl = cp.par
    rtol = ad.rtol
    out_dt = ad.out_dt
    n_rec = ad.n_rec
    K = w.K
    ynew = w.ynew
    force = w.force
    peaks = out.peaks
    ctab = tr.tables
    n = tr.veh.shape[0]
    split = w.air.shape[1] > 0  # the fluid brake's pneumatics on their own steps
    air_st = w.air_step[0]
    # the mechanical states (all of them without the fluid brake), stepped here
    ny = tr.air.index[I_PIPE] if split else y.shape[0]
    ym = y[:ny]
    speed_mode = drv[D_MODE] == MODE_SPEED
    ts = drv[D_TS]
    braking = (drv[D_BSLEN] + drv[D_BPLEN] + drv[D_BCTRL]) > 0.0
    m_sched = int(drv[D_BSLEN])
    o_sched = int(drv[D_BSOFF])
    h = sp["h"]
    t = sp["t"]
    r = r_start
    t_last = (n_rec - 1) * out_dt
    t_stop = min(r_stop, n_rec - 1) * out_dt
    eps = 1e-9 * out_dt
    fresh = True  # K[0:ny] must be (re)computed at (t, y)
    cut = False  # the pneumatic step must end at t (a command, or the start)
    if split and not air_st["started"]:
        _air_start(t, y, tr, w)
        cut = True
    while True:
        # ---- driver: controller sample, brake commands (at the start of the step)
        sampled = speed_mode and _sample_due(t, st, ts, eps)
        if sampled:
            _controller(t, y, ctl, tr, dr, w)
            fresh = True
        if braking:
            issued = _brake_commands(t, eps, y, ctl, tr, dr, w, sampled)
            if issued < 0:
                sp["h"] = h
                sp["t"] = t
                return EVENTS_FULL, t
            if issued > 0:
                fresh = True
                cut = split  # the pneumatic step ends here, with the new command's rates
        a_dem = st["a_dem"]
        n_ev = st["n_events"]
        if cut:
            _air_cut(t, ctl.events, n_ev, tr, w)
            cut = False
        if fresh:
            rhs_split(t, ym, a_dem, n_ev, tr, cp, dr, ctl.events, w, K[0:ny])
            _track_peaks(force, peaks, n - 1, t)
            fresh = False
        # ---- record when on a record time
        if r < n_rec and abs(t - r * out_dt) <= eps:
            if r < r_stop or r == n_rec - 1:
                if split:
                    _air_interpolate(t, tr, w, y)
                _record(r, t, y, K, a_dem, st["level"], speed_mode, tr, dr, w, out)
            r += 1
        if t >= t_stop - eps or t >= t_last - eps:
            break
        # ---- the next step ends no later than the next record, sample or command
        t_next = r * out_dt
        if speed_mode:
            t_next = min(t_next, st["next_sample"] * ts)
        k = st["next_scheduled"]
        if k < m_sched:
            t_next = min(t_next, ctab[o_sched + k])
        h_try = min(h, ad.h_max)
        if split:
            if (min(t + h_try, t_next) > air_st["t1"] and t >= air_st["t0"]
                    and t < t_last - eps):
                # the step would pass the pneumatic step's end: take the next pneumatic
                # step (to the next scheduled command at most), keeping the one the
                # mechanical step starts in, so that the step need not end there
                t_cap = t_last
                k = st["next_scheduled"]
                if k < m_sched and ctab[o_sched + k] > t + eps:
                    t_cap = min(t_cap, ctab[o_sched + k])
                if not _air_step(t_cap, ctl.events, n_ev, tr, w, ad):
                    sp["h"] = h
                    sp["t"] = t
                    return NONFINITE, t
            t_next = min(t_next, air_st["t1"])
        hit = False
        if t + h_try >= t_next - eps:
            h_try = t_next - t
            hit = True
        # ---- one step of the embedded pair: its stages, the solution kept, the error
        _stages(_train_rhs_split, (a_dem, n_ev, tr, cp, dr, ctl.events, w), t, ym, h_try, A,
                C, ns, K, w.ytmp)
        # (the pair's three stages written out: one pass over the state for the solution
        # and one for the error, the same sums in the same order. The heavy-haul train
        # over 20 s runs 6 % fewer instructions in all than with a pass per stage, and
        # a loop over the stages inside the loop over the state runs 35 % more)
        b0, b1, b2 = B[0], B[1], B[2]
        finite = True
        for q in range(ny):
            v = y[q] + h_try * (b0 * K[q] + b1 * K[ny + q] + b2 * K[2 * ny + q])
            ynew[q] = v
            # (a flag, not a running sum: no chain of dependent additions; 1 % fewer
            # instructions per heavy-haul step)
            finite &= (v - v) == 0.0
        t_new = t_next if hit else t + h_try
        err = np.inf
        if finite:
            # the right-hand side at the step's end: the error's last stage, and the next
            # step's first if the step is accepted (first same as last)
            rhs_split(t_new, ynew[:ny], a_dem, n_ev, tr, cp, dr, ctl.events, w,
                      K[ns * ny:(ns + 1) * ny])
            e0, e1, e2, e3 = E[0], E[1], E[2], E[3]
            err = 0.0
            for q in range(ny):
                e = h_try * (e0 * K[q] + e1 * K[ny + q] + e2 * K[2 * ny + q]
                             + e3 * K[3 * ny + q])
                sc = err_atol[q] + rtol[q] * max(abs(y[q]), abs(ynew[q]))
                e = abs(e) / sc
                if e > err:
                    err = e
            # the stage weights of the slack test, and the slack's decay for one rate at
            # a time (the gears mostly share one: one exponential per step)
            w10 = h_try * A[1, 0]
            w20 = h_try * A[2, 0]
            w21 = h_try * A[2, 1]
            rate_last = -1.0
            decay = 1.0
            for g in range(gear_f1.shape[0]):
                q = gear_f1[g]
                j = gear_of[g]
                qp = gear_plate[g]
                if gear_exact[g] and _slack_throughout(j, y, ynew, K, ny, w10, w20, w21,
                                                       cpl):
                    # the gear spent the step in its slack, where its states relax to
                    # constants and act on nothing: relax them exactly (no error)
                    rate = cpl[j, P_RATE]
                    if rate != rate_last:
                        decay = np.exp(-rate * h_try)
                        rate_last = rate
                    _relax_in_slack(j, q, qp, y, ynew, K[ns * ny:], decay, cpl)
                    continue
                e = h_try * (e0 * K[q] + e1 * K[ny + q] + e2 * K[2 * ny + q]
                             + e3 * K[3 * ny + q])
                e = _exerted_error(ynew[q], e, abs(force[j]), cpl[j, P_F0])
                e = e / (atol[q] + rtol[q] * max(abs(y[q]), abs(ynew[q])))
                if e > err:
                    err = e
                if qp >= 0:
                    e = h_try * (e0 * K[qp] + e1 * K[ny + qp] + e2 * K[2 * ny + qp]
                                 + e3 * K[3 * ny + qp])
                    e = abs(e) / (atol[qp] + rtol[qp] * max(abs(y[qp]), abs(ynew[qp])))
                    if e > err:
                        err = e
            if not (err - err == 0.0):
                err = np.inf
        if err <= 1.0:
            t = t_new
            for q in range(ny):
                y[q] = ynew[q]
                K[q] = K[ns * ny + q]  # first same as last
            _track_peaks(force, peaks, n - 1, t)
            sp["accepted"] += 1
            # PI step-size control (Gustafsson): smoother step sequences, fewer rejections
            if err == 0.0:
                fac = 5.0
            else:
                fac = 0.9 * err ** (-0.7 / 3.0) * max(sp["last_error"], 1e-4) ** (0.4 / 3.0)
                fac = min(5.0, max(0.2, fac))
            if sp["last_rejected"]:  # no growth right after a rejection
                fac = min(fac, 1.0)
            sp["last_error"] = err
            sp["last_rejected"] = False
            if not hit or fac < 1.0:
                h = h_try * fac
            else:  # a step shortened to land on a target says little about the next one
                h = max(h, h_try * fac)
        else:
            sp["rejected"] += 1
            sp["last_rejected"] = True
            fac = 0.2 if err == np.inf else max(0.2, 0.9 * err ** (-1.0 / 3.0))
            h = h_try * fac
            if h < 1e-12:
                sp["h"] = h
                sp["t"] = t
                return NONFINITE, t
    sp["h"] = h
    sp["t"] = t
    return OK, t


@njit(cache=True, _nrt=False, forceinline=True)
def _record(r, t, y, dy, a_dem, level, speed_mode, tr, dr, w, out):
    """Write record ``r`` at time ``t`` (s) of state ``y`` to ``out``: positions,
    speeds, the accelerations ``dy[n:2n]`` (stage 1 at ``(t, y)``), coupler
    deflections and forces, brakes and consist forces from ``w``, the scalar signals
    with the held demand ``a_dem`` (m/s^2) and the last brake level (0-1). A record
    array of width 0 is one the run does not record (``solver.record``)."""
    veh = tr.veh
    cons = tr.cons
    trac = tr.trac
    out_s = out.s
    n = veh.shape[0]
    for i in range(out.x.shape[1]):
        out.x[r, i] = y[i] + veh[i, V_P0]  # track position
    for i in range(out.v.shape[1]):
        out.v[r, i] = y[n + i]
    for i in range(out.a.shape[1]):
        out.a[r, i] = dy[n + i]  # stage-1 derivatives sit at offset 0
    for j in range(out.d.shape[1]):
        out.d[r, j] = w.defl[j]
    for j in range(out.f.shape[1]):
        out.f[r, j] = w.force[j]
    fluid = w.inflow.shape[0] > 0  # the fluid brake's pipe cells
    for i in range(out.b.shape[1]):
        out.b[r, i] = w.bforce[i] if veh[i, V_BZ] >= 0 else 0.0
    if not fluid:
        for i in range(out.p.shape[1]):
            zb = int(veh[i, V_BZ])
            out.p[r, i] = y[zb] if zb >= 0 else 0.0
    else:
        atm = tr.air.gas[A_ATM]
        zp = tr.air.index[I_PIPE]
        for i in range(out.bp.shape[1]):
            out.bp[r, i] = y[zp + int(veh[i, V_BCELL])] - atm
        for i in range(n):
            zb = int(veh[i, V_BZ])
            aux = y[zb + CV_AUX] - atm if zb >= 0 else np.nan
            cyl = y[zb + CV_CYL] - atm if zb >= 0 else np.nan
            if out.ar.shape[1] > 0:
                out.ar[r, i] = aux
            if out.bc.shape[1] > 0:
                out.bc[r, i] = cyl
            if out.p.shape[1] > 0:
                out.p[r, i] = cyl / veh[i, V_BPFS] if zb >= 0 else 0.0
        if out.ax.shape[1] > 0:
            out.ax[r, 0] = y[tr.air.index[I_EXH]]
    if out.c.shape[1] > 0:
        for c in range(cons.shape[0]):
            out.c[r, c] = w.fcons[c]
    for kd in range(out.m.shape[1]):
        for q in range(N_DRIVE_SIGNALS):
            out.m[r, kd, q] = w.dsig[kd, q]
    ne = out.e.shape[1]
    if ne > 0:
        ez = int(trac[T_EZ])  # (run_adaptive integrates them as states, run sums them)
        for q in range(ne - 1):
            out.e[r, q] = y[ez + q] if ez >= 0 else w.energy[q]
        kin = 0.0
        for i in range(n):
            kin += 0.5 * veh[i, V_MASS] * y[n + i] * y[n + i]
        out.e[r, ne - 1] = kin
    sig = w.sig[0]
    out_s[r, S_TRACTION] = sig["traction"]
    adh = 0.0
    for c in range(cons.shape[0]):
        adh += adhesion_max(y[n + int(cons[c, K_VEH])], cons[c, K_MADH], trac[T_G])
    out_s[r, S_ADHESION] = adh
    out_s[r, S_DEMAND] = sig["demand"]
    out_s[r, S_BRAKE] = level
    if speed_mode:
        out_s[r, S_VREF] = _interp(dr.prof_t, dr.prof_y, t, w.hints, n + 1)
        out_s[r, S_ADEM] = a_dem
    else:
        out_s[r, S_VREF] = np.nan
        out_s[r, S_ADEM] = np.nan
