"""Column layouts of the lowered tables the compiled kernel reads.

Each table is a float64 array whose columns are named here once, as a tuple of column
names; :func:`layout` turns the tuple into consecutive column indices, unpacked into
module-level integer constants (``V_MASS``, ``K_TAU``, ...). Numba freezes module-level
integers into the compiled code as constants, so a named column costs exactly what a
literal index did. A table's width is the length of its name tuple, never counted by
hand; unpacking into the wrong number of constants fails at import.

Tables (the coupler table's layout lives with the coupler models, in
:mod:`ltdsim.coupler_models`):

* vehicle table ``veh``, one row per vehicle, ``V_*`` columns;
* locomotive consist table ``cons``, one row per consist, ``K_*`` columns;
* traction vector ``trac``, ``T_*`` slots;
* driver vector ``drv``, ``D_*`` slots.

Only the engine (:mod:`ltdsim.lowering`, :mod:`ltdsim.kernel`,
:mod:`ltdsim.coupler_models`) imports these constants; every other module reads lowered
data through :class:`ltdsim.lowering.Lowered`'s properties or works from the validated
:class:`~ltdsim.scenario.Scenario`.
"""

from __future__ import annotations


def layout(*names: str, start: int = 0) -> range:
    """Column indices ``start, start + 1, ...`` of the columns ``names`` (one each)."""
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate column names in {names}")
    return range(start, start + len(names))


#: vehicle table: mass kg, weight mass kg, Davis a N, b N s/m, c N s^2/m^2, inverse
#: standstill speed 1/v0 s/m (resistance.PURE_SIGN for v0 = 0), share of its consist's
#: traction -, initial position m, consist index (0 with share 0 when unpowered); brake:
#: state index in y (-1 unbraked), full-application shoe force N (cylinder force x rigging
#: ratio), force per shoe at full application N, friction model code, constant mu -,
#: friction table offset and length in the table store, brake-pipe signal delay from the
#: nearest control point s
VEHICLE_COLUMNS = ("mass", "weight_mass", "davis_a", "davis_b", "davis_c", "inv_v0",
                   "share", "p0", "consist", "brake_state", "brake_full", "brake_shoe",
                   "brake_friction", "brake_mu", "brake_table", "brake_table_len",
                   "brake_delay")
(V_MASS, V_WMASS, V_DA, V_DB, V_DC, V_DIV0, V_SHARE, V_P0, V_CONS, V_BZ, V_BFULL, V_BSHOE,
 V_BFRIC, V_BMU, V_BTAB, V_BNTAB, V_BDELAY) = layout(*VEHICLE_COLUMNS)
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
#: m/s^2, index of the vehicle whose speed is controlled
TRACTION_SLOTS = ("max_force", "max_power", "adhesion_mass", "max_accel", "max_decel",
                  "feedforward", "demand_mass", "gravity", "speed_vehicle")
(T_FMAX, T_PMAX, T_MADH, T_AMAX, T_DMAX, T_FF, T_MTOT, T_G, T_REF) = layout(*TRACTION_SLOTS)
N_TRAC = len(TRACTION_SLOTS)

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
                "anti_windup")
(D_MODE, D_KP, D_KI, D_KD, D_N, D_TS, D_INT, D_FILT,
 D_BSOFF, D_BSLEN, D_BPOFF, D_BPLEN, D_BCTRL, D_BSTEP, D_BTAUA, D_BTAUR, D_BVS,
 D_BSHOEREF, D_BFULLSUM, D_AW) = layout(*DRIVER_SLOTS)
N_DRV = len(DRIVER_SLOTS)

#: driver modes (the ``D_MODE`` slot)
DRIVER_MODES = ("speed", "force", "notch")
MODE_SPEED, MODE_FORCE, MODE_NOTCH = layout(*DRIVER_MODES)
