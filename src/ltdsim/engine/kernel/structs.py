"""The named structures the kernels take, and their builders.

``NamedTuple`` classes of arrays (:class:`Train` with its :class:`AirBrake` and
:class:`Drive`, :class:`CouplerArrays`, :class:`DriverArrays`, :class:`Controller`,
:class:`FixedStep`, :class:`Adaptive`, :class:`Work`, :class:`Outputs`), whose tables
are flat arrays with the columns of :mod:`ltdsim.engine.layout` and
:mod:`ltdsim.engine.couplers`; the states that carry over between calls (controller,
bs23 step control, the right-hand side's signals) are numpy records with named fields
(``CONTROLLER``, ``STEPPER``, ``AIR_STEPPER``, ``SIGNALS``), read as ``st["a_dem"]``.
Numba compiles a kernel once per set of argument types and finds it in its on-disk
cache by the classes' import names, so the classes live at module level here. The
builders (``make_*``) turn a :class:`~ltdsim.engine.lowering.Lowered` scenario into
them; :func:`work_size` counts the :class:`Work` without allocating it, from the same
shapes :func:`make_work` allocates.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ltdsim.engine.couplers import M_CUSHION, M_SIMPLIFIED, MODELS
from ltdsim.engine.features import CouplerKinds, Features, compiled_set, flag
from ltdsim.engine.layout import N_DRIVE_SIGNALS, N_ENERGY, V_MASS, V_SHARE
from ltdsim.physics.control import PID_STATE
from ltdsim.physics.drive.foc import N_OUT

#: kernel return codes: done, a state not finite, the brake-command table full, a finite
#: state beyond any physical bound (recording._implausible)
OK, NONFINITE, EVENTS_FULL, ABSURD = 0, 1, 2, 3

#: columns of the recorded scalar signals
SG_TRACTION, SG_VREF, SG_ADHESION, SG_ADEM, SG_DEMAND, SG_BRAKE = range(6)
N_SCALARS = 6

#: columns of the peak-force table, one row per coupler: largest force N, smallest
#: force N, time of the largest s, time of the smallest s
PK_MAX, PK_MIN, PK_TMAX, PK_TMIN = range(4)
N_PEAKS = 4


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
                    ("last_rejected", np.bool_), ("holds", np.int64)])

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
#: end row and the running sums of its samples (:func:`_powers`);
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
    volume: np.ndarray  # (cells,) cell volumes (bore and side volumes), m^3
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
    features: Features  # the subsystems compiled in (ltdsim.engine.features)


class CouplerArrays(NamedTuple):
    """The lowered couplers, coupler j joining vehicles j and j + 1."""

    model: np.ndarray  # (n - 1,) int64 model codes (ltdsim.engine.couplers.MODEL_NAMES)
    par: np.ndarray  # (n - 1, N_CCOL) parameters (columns: ltdsim.engine.couplers)
    uniform: int  # the model code every coupler has, -1 for a mix (see uniform_model)
    kinds: CouplerKinds  # the gear models compiled in (ltdsim.engine.features)


class DriverArrays(NamedTuple):
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
    energy_every: int  # steps between samples of the body powers (solver.energy), a
    #                    divisor of record_every
    A: np.ndarray  # (stages, stages) Butcher tableau
    b: np.ndarray  # (stages,) weights
    c: np.ndarray  # (stages,) nodes


class Adaptive(NamedTuple):
    """An embedded Runge-Kutta pair under error control (bs23,
    :data:`ltdsim.engine.integrators.BS23`) and the run's record grid. :func:`run_adaptive`
    writes the pair's sums out for its three stages."""

    out_dt: float  # time between records, s
    n_rec: int  # records of the whole run
    hold_speed: float  # a coupling meeting its slack edge slower than this is held, m/s
    #                    (0: none is; solver.hold_speed, kernel.slack._hold_enter)
    hold_ftol: float  # how far a held force may pass its range in a step uncut, N
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
    feed: np.ndarray  # (pipe cells,) fluid brake: the valves' feed into each cell, kg/s
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
    held: np.ndarray  # (n - 1,) or (0,) without solver.hold_speed; int64: each coupling held at its slack edge, +1
    #                   in draft, -1 in buff, 0 free (run_adaptive, solver.hold_speed)
    hold_f: np.ndarray  # (as held) the force up to which it may be held, N (0: never)
    hold_fs: np.ndarray  # (as held) its force at the current step's start, N


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


def make_train(low) -> Train:
    """:class:`Train` of a :class:`~ltdsim.engine.lowering.Lowered` scenario."""
    air = AirBrake(gas=low.air_gas, index=low.air_index, dx_cell=low.pipe_dx_cell,
                   dx_face=low.pipe_dx_face, leak=low.pipe_leak, volume=low.pipe_volume,
                   cv=low.cv_rows,
                   dv=low.dv_rows, dv_cell=low.dv_cell)
    drive = Drive(of=low.drive_of, z=low.drive_z, motor=low.drive_motor,
                  ctrl=low.drive_ctrl, ws=low.drive_ws, rail=low.drive_rail,
                  slip=low.drive_slip, misc=low.drive_misc)
    return Train(veh=low.veh, powered=np.flatnonzero(low.veh[:, V_SHARE] > 0.0).astype(np.int64),
                 inv_m=1.0 / low.veh[:, V_MASS], cons=low.cons, trac=low.trac,
                 track_pos=low.track_pos, track_grade=low.track_grade,
                 track_curv=low.track_curv, curve_h=low.curve_h, tables=low.ctab, air=air,
                 drive=drive, features=compiled_set(features_of(low),
                                                    coupler_kinds(low.cpl_model))[0])


def features_of(low) -> Features:
    """The optional subsystems a :class:`~ltdsim.engine.lowering.Lowered` scenario runs:
    the fluid brake, an induction drive, the energy accounting (the kernel is compiled
    for the smallest set that holds them, :func:`ltdsim.engine.features.compiled_set`)."""
    return Features(fluid=flag(low.fluid), drive=flag(low.drive_z.shape[0] > 0),
                    energy=flag(bool(low.energy)))


def coupler_kinds(model: np.ndarray) -> CouplerKinds:
    """The gear models among the couplers' model codes ``model`` (int64) whose code the
    kernel compiles only when some coupler has them."""
    codes = set(int(m) for m in model)
    hysteretic = {m.code for m in MODELS if m.hysteretic}
    return CouplerKinds(hysteretic=flag(bool(codes & hysteretic)),
                        cushion=flag(M_CUSHION in codes),
                        dispatch=flag(bool(codes - {M_SIMPLIFIED})))


def make_couplers(low) -> CouplerArrays:
    """:class:`CouplerArrays` of a :class:`~ltdsim.engine.lowering.Lowered` scenario."""
    return CouplerArrays(model=low.cpl_model, par=low.cpl, uniform=uniform_model(low.cpl_model),
                         kinds=compiled_set(features_of(low), coupler_kinds(low.cpl_model))[1])


def uniform_model(model: np.ndarray) -> int:
    """The model code that every coupler of ``model`` (int64 codes) has, or -1 when
    they differ or there is none (:class:`CouplerArrays`' ``uniform``)."""
    if model.shape[0] == 0 or not (model == model[0]).all():
        return -1
    return int(model[0])


def make_driver(low) -> DriverArrays:
    """:class:`DriverArrays` of a :class:`~ltdsim.engine.lowering.Lowered` scenario."""
    return DriverArrays(par=low.drv, prof_t=low.prof_t, prof_y=low.prof_y)


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


def _work_shapes(n: int, ny: int, stages: int, n_consists: int, cells: int,
                 air_steps: bool, drives: int, energy: bool, hold: bool = False) -> dict:
    """Shape and dtype of every :class:`Work` array (arguments as :func:`make_work`):
    the one declaration that :func:`make_work` allocates and :func:`work_size` counts."""
    nc = max(n - 1, 1)
    ne = N_ENERGY + n - 1 if energy else 0
    nh = max(n - 1, 0) if hold else 0
    f8, i8 = np.float64, np.int64
    return {"K": ((stages * ny,), f8), "ytmp": ((ny,), f8), "ynew": ((ny,), f8),
            "force": ((nc,), f8), "defl": ((nc,), f8), "res": ((n,), f8),
            "bforce": ((n,), f8), "fcons": ((n_consists,), f8), "sig": ((1,), SIGNALS),
            "hints": ((n + 2 + n_consists,), i8), "tkey": ((n,), i8),
            "tres": ((n, 2), f8), "inflow": ((cells,), f8), "feed": ((cells,), f8),
            "air": ((N_AIR_ROWS, ny if air_steps else 0), f8),
            "air_step": ((1,), AIR_STEPPER), "ddem": ((drives,), f8),
            "dsig": ((drives, N_DRIVE_SIGNALS), f8), "dout": ((drives, N_OUT), f8),
            "energy": ((ne,), f8), "pw": ((3, ne), f8), "fprev": ((n_consists,), f8),
            "bforce_on": ((1,), np.bool_),
            "held": ((nh,), i8), "hold_f": ((nh,), f8), "hold_fs": ((nh,), f8)}


def make_work(n: int, ny: int, stages: int, n_consists: int, cells: int = 0,
              air_steps: bool = False, drives: int = 0, energy: bool = False,
              braked: bool = False, hold: bool = False) -> Work:
    """:class:`Work` for ``n`` vehicles, a state of ``ny`` elements, ``stages`` stage
    derivatives, ``n_consists`` locomotive consists and ``cells`` brake-pipe cells
    (fluid brake); ``air_steps``: the fluid brake's pneumatic states take their own
    steps (:func:`run_adaptive` with ``brake.model = "fluid"``); ``drives`` induction
    drives; ``energy``: the run accounts for the energy (``solver.energy``); ``braked``:
    some vehicle has an air brake; ``hold``: couplings may be held at their slack
    edges (``solver.hold_speed``; else the held arrays are empty, and the kernels'
    loops over them run no iteration). Zeros but for: no track segment yet in ``tkey``
    (-1), the pneumatic stepper's first step 0.1 ms, ``bforce_on`` = ``braked``."""
    shapes = _work_shapes(n, ny, stages, n_consists, cells, air_steps, drives, energy, hold)
    w = Work(**{k: np.zeros(shape, dtype=dt) for k, (shape, dt) in shapes.items()})
    w.tkey[:] = -1
    w.air_step[0]["h"] = 1e-4
    w.air_step[0]["last_error"] = 1.0
    w.bforce_on[0] = braked
    return w


def work_size(n: int, ny: int, stages: int, n_consists: int = 1, cells: int = 0,
              air_steps: bool = False, drives: int = 0, energy: bool = False,
              hold: bool = False) -> int:
    """Elements of 8 bytes that hold the :class:`Work` :func:`make_work` builds for the
    same arguments (rounded up), counted without allocating it (the memory check
    before a run)."""
    shapes = _work_shapes(n, ny, stages, n_consists, cells, air_steps, drives, energy, hold)
    nbytes = sum(int(np.prod(shape)) * np.dtype(dt).itemsize for shape, dt in shapes.values())
    return -(-nbytes // 8)
