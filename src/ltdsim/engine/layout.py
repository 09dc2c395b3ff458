"""Column layouts of the lowered tables the compiled kernel reads.

Each table is a float64 array whose columns are named here once, as a tuple of column
names; :func:`layout` turns the tuple into consecutive column indices, unpacked into
module-level integer constants (``V_MASS``, ``K_TAU``, ...). Numba freezes module-level
integers into the compiled code as constants, so a named column costs exactly what a
literal index did. A table's width is the length of its name tuple, never counted by
hand; unpacking into the wrong number of constants fails at import.

Tables (the coupler table's layout lives with the coupler models, in
:mod:`ltdsim.engine.couplers`):

* vehicle table ``veh``, one row per vehicle, ``V_*`` columns;
* locomotive consist table ``cons``, one row per consist, ``K_*`` columns;
* traction vector ``trac``, ``T_*`` slots;
* driver vector ``drv``, ``D_*`` slots.

Only the engine (:mod:`ltdsim.engine.lowering`, :mod:`ltdsim.engine.kernel`,
:mod:`ltdsim.engine.couplers`) imports these constants; every other module reads lowered
data through :class:`ltdsim.engine.lowering.Lowered`'s properties or works from the validated
:class:`~ltdsim.scenario.Scenario`.
"""

from __future__ import annotations

from ltdsim.variables import DRIVE_SIGNALS, ENERGY_TERMS  # (their orders: the columns')


def layout(*names: str, start: int = 0) -> range:
    """Column indices ``start, start + 1, ...`` of the columns ``names`` (one each)."""
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate column names in {names}")
    return range(start, start + len(names))


def append_table(tables: list[float], values) -> int:
    """Append ``values`` to the flat table store ``tables`` (the kernel's
    ``Train.tables``: curves, friction tables, schedules) and return their offset."""
    off = len(tables)
    tables.extend(float(v) for v in values)
    return off


#: vehicle table: mass kg, weight mass kg, Davis a N, b N s/m, c N s^2/m^2, inverse
#: standstill speed 1/v0 s/m (resistance.PURE_SIGN for v0 = 0), share of its consist's
#: traction -, initial position m, consist index (0 with share 0 when unpowered); brake:
#: state index in y (-1 unbraked), full-application shoe force N (cylinder force x rigging
#: ratio), force per shoe at full application N, friction model code, constant mu -,
#: friction table offset and length in the table store, brake-pipe signal delay from the
#: nearest control point s. Fluid brake (``brake.model = "fluid"``; the brake state index
#: is then the first of the vehicle's control-valve states): the pipe cell its valve
#: connects to (every vehicle: where its pipe pressure is read), its control-valve row in
#: ``AirBrake.cv``, piston area m^2, return spring N, efficiency x rigging ratio -, 1 /
#: shoes -, and the cylinder pressure of a full service Pa gauge (for the fill)
VEHICLE_COLUMNS = ("mass", "weight_mass", "davis_a", "davis_b", "davis_c", "inv_v0",
                   "share", "p0", "consist", "brake_state", "brake_full", "brake_shoe",
                   "brake_friction", "brake_mu", "brake_table", "brake_table_len",
                   "brake_delay", "pipe_cell", "valve_row", "piston_area", "return_spring",
                   "brake_gain", "inv_shoes", "full_service_pressure")
(V_MASS, V_WMASS, V_DA, V_DB, V_DC, V_DIV0, V_SHARE, V_P0, V_CONS, V_BZ, V_BFULL, V_BSHOE,
 V_BFRIC, V_BMU, V_BTAB, V_BNTAB, V_BDELAY, V_BCELL, V_BCV, V_BAREA, V_BSPRING, V_BGAIN,
 V_BINVSHOES, V_BPFS) = layout(*VEHICLE_COLUMNS)
N_VCOL = len(VEHICLE_COLUMNS)

#: locomotive consist table: traction curve (largest force N, power W, adhesion mass kg),
#: share of the driver's force demand -, lag time constant s, force rate limit N/s (0
#: none), lag state index in y (-1 none), vehicle whose speed it reads, own notch profile
#: (offset and length in the table store; length 0 = follows the driver), speed below
#: which dynamic braking fades m/s (0 none)
CONSIST_COLUMNS = ("max_force", "max_power", "adhesion_mass", "share", "time_constant",
                   "rate_limit", "lag_state", "speed_vehicle", "notch_offset", "notch_len",
                   "dynamic_brake_fade")
(K_FMAX, K_PMAX, K_MADH, K_SHARE, K_TAU, K_RATE, K_Z, K_VEH, K_NOFF, K_NLEN,
 K_DBFADE) = layout(*CONSIST_COLUMNS)
N_KCOL = len(CONSIST_COLUMNS)

#: traction vector: the lead consist's curve (N, W, kg), the speed controller's output
#: limits m/s^2, feedforward flag (0/1), the mass its output multiplies kg, gravity
#: m/s^2, index of the vehicle whose speed is controlled, index in y of the first energy
#: state (bs23 with solver.energy: the energy terms integrated as states; -1 otherwise)
TRACTION_SLOTS = ("max_force", "max_power", "adhesion_mass", "max_accel", "max_decel",
                  "feedforward", "demand_mass", "gravity", "speed_vehicle", "energy_state")
(T_FMAX, T_PMAX, T_MADH, T_AMAX, T_DMAX, T_FF, T_MTOT, T_G, T_REF, T_EZ) = layout(
    *TRACTION_SLOTS)
N_TRAC = len(TRACTION_SLOTS)

#: the energy totals (``solver.energy = true``; the kernel's ``Work.energy``, or states
#: from ``T_EZ`` under bs23), each the
#: work done since the start, J: traction at the rail while motoring (its power > 0),
#: dynamic braking at the rail (the energy the locomotives take back, >= 0), air brakes,
#: Davis resistance, grade (the potential energy gained), curve resistance; then one per
#: coupler, the net work it has taken (what its gears dissipated plus what they store)
(E_MOTOR, E_DYN, E_AIR, E_DAVIS, E_GRADE, E_CURVE) = layout(*ENERGY_TERMS)
N_ENERGY = len(ENERGY_TERMS)

#: driver vector: mode code (MODE_*); PID kp 1/s, ki 1/s^2, kd -, filter n 1/s, sample
#: time s, integrator and filter discretisation codes; brake schedule and position
#: triggers (offsets and lengths in the table store); controller-made applications
#: (0/1), their level step -; cylinder apply and release time constants s, standstill
#: speed m/s; mean shoe force at full application N and the train's total full shoe
#: force N (0 = no brakes) for the controller's blending; PID anti-windup (0/1)
DRIVER_SLOTS = ("mode", "kp", "ki", "kd", "n", "ts", "integrator", "filter",
                "brake_schedule", "brake_schedule_len", "brake_positions",
                "brake_positions_len", "brake_controller", "brake_step", "apply_tau",
                "release_tau", "standstill_speed", "shoe_force_ref", "full_shoe_sum",
                "anti_windup", "brake_model")
(D_MODE, D_KP, D_KI, D_KD, D_N, D_TS, D_INT, D_FILT,
 D_BSOFF, D_BSLEN, D_BPOFF, D_BPLEN, D_BCTRL, D_BSTEP, D_BTAUA, D_BTAUR, D_BVS,
 D_BSHOEREF, D_BFULLSUM, D_AW, D_BMODEL) = layout(*DRIVER_SLOTS)
N_DRV = len(DRIVER_SLOTS)

#: brake models (the ``D_BMODEL`` slot)
BRAKE_MODELS = ("lumped", "fluid")
BRAKE_LUMPED, BRAKE_FLUID = layout(*BRAKE_MODELS)

#: fluid brake's gas and pipe constants (``AirBrake.gas``): ratio of specific heats -,
#: gas constant J/(kg K), the ambient temperature (the pipe wall's and the valves') K,
#: atmosphere Pa abs, the orifice law's linear ratio -, dynamic viscosity Pa s, pipe bore
#: area m^2, bore diameter m, wall roughness m, the pipe air's thermal mode
#: (``brakepipe.THERMAL_*`` code), thermal conductivity of air W/(m K)
AIR_SLOTS = ("gamma", "r_gas", "temperature", "atmosphere", "r_lin", "viscosity",
             "area", "diameter", "roughness", "thermal", "conductivity")
(A_GAMMA, A_RGAS, A_TEMP, A_ATM, A_RLIN, A_VISC, A_AREA, A_DIAM, A_ROUGH, A_THERMAL,
 A_COND) = layout(*AIR_SLOTS)
N_AIR = len(AIR_SLOTS)

#: fluid brake's state offsets and counts (``AirBrake.index``, int64): first pipe cell
#: pressure, number of cells, first control-valve state, first driver's-valve state,
#: the exhausted-air accumulator, number of brake-control points. The pipe's states are
#: its cell pressures (cells), face flows (cells - 1) and cell densities (cells), in
#: that order from the first
AIR_INDEX = ("pipe", "cells", "valves", "drivers", "exhausted", "control_points")
(I_PIPE, I_CELLS, I_CV, I_DV, I_EXH, I_NCP) = layout(*AIR_INDEX)
N_AIR_INDEX = len(AIR_INDEX)

#: driver modes (the ``D_MODE`` slot)
DRIVER_MODES = ("speed", "force", "notch")
MODE_SPEED, MODE_FORCE, MODE_NOTCH = layout(*DRIVER_MODES)

#: columns of a brake command (the kernel's event store, and the brake schedules in the
#: table store, one column after the other): time s (schedules: time s or the lead's
#: position m), brake level 0-1, kind (``CMD_*``), value (a service reduction, Pa)
EVENT_COLUMNS = ("time", "level", "kind", "value")
(EV_TIME, EV_LEVEL, EV_KIND, EV_VALUE) = layout(*EVENT_COLUMNS)
N_EVENT_COLUMNS = len(EVENT_COLUMNS)
#: kinds of brake command: by the level alone (brake_profile, brake_positions, the speed
#: controller; the fluid brake makes a level L > 0 a service reduction of L x the
#: full-service one and 0 a release), release (running), service (value: the
#: reduction, Pa), emergency, lap (the driver's valve holds), fast fill (UIC)
COMMAND_KINDS = ("level", "release", "service", "emergency", "lap", "fast_fill")
CMD_LEVEL, CMD_RELEASE, CMD_SERVICE, CMD_EMERGENCY, CMD_LAP, CMD_FAST_FILL = layout(
    *COMMAND_KINDS)

#: columns of an induction drive's row of further constants (``Lowered.drive_misc``,
#: traction.drive = "induction"): motors (= driven wheelsets) of the consist, gear
#: efficiency -, DC-link voltage V, slip control on (1) or off (0), factor from the peak
#: line current to the rms winding current -, motors per locomotive, dynamic-brake fade
#: speed m/s
DRIVE_MISC = ("motors", "gear_efficiency", "dc_link_voltage", "slip_control", "to_rms",
              "per_locomotive", "fade")
(DM_MOTORS, DM_GEAR_EFF, DM_VDC, DM_SLIP_ON, DM_TO_RMS, DM_PER_LOCO, DM_FADE) = layout(
    *DRIVE_MISC)
N_DRIVE_MISC = len(DRIVE_MISC)
#: the induction drives' recorded signals per consist (kernel ``Work.dsig`` and the
#: record ``Outputs.m``): motor torque N m, motor speed rad/s, stator current A rms
#: winding, creep -, creep force per locomotive N, DC power per locomotive W; one motor's
#: flux linkages in the controller's synchronous frame, Wb (peak): stator d, q, rotor d, q
(DS_TORQUE, DS_SPEED, DS_CURRENT, DS_CREEP, DS_FORCE, DS_PDC, DS_PSD, DS_PSQ, DS_PRD,
 DS_PRQ) = layout(*DRIVE_SIGNALS)
N_DRIVE_SIGNALS = len(DRIVE_SIGNALS)

#: bounds of a plausible state, checked at every record (:func:`ltdsim.engine.kernel.
#: recording._implausible`): a state beyond them is a run that has blown up while staying
#: finite (an explicit method past its stability limit with solver.stability_check off,
#: say), and the run stops there instead of reporting it. No rail vehicle has run faster
#: than 160 m/s (574.8 km/h, TGV V150, 2007): 1,000 m/s is beyond any train. A coupler
#: deflected by more than 10 m has its vehicles through each other or apart by a car's
#: length, where the longest gear travels 0.2 m. A brake pipe below vacuum or above 100
#: bar (absolute) is beyond any air brake (pipes run at 5-7.6 bar gauge, main reservoirs
#: at 8-10.3 bar).
ABSURD_SPEED = 1e3  # m/s
ABSURD_DEFLECTION = 10.0  # m
ABSURD_PRESSURE = 1e7  # Pa, absolute
