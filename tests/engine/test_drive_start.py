"""The induction drive starts in its steady state at any speed (foc.drive_steady, used by
lowering for the initial state): each check against something independent of the
kernel's result: the drive's own rates (zero at an equilibrium), the machine's phasor
equivalent circuit, the steady-state voltage equations in closed form, the drive's
documented limits (current limit at rated flux, power over shaft speed) and the demand.

Before the change a drive started at speed began magnetised at standstill: at 20 m/s
with no demand the stator current rose to 2365 A against the 310 A limit and the wheels
braked the locomotive with -272 kN (docs/induction-drive-train.md, Start at speed)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ltdsim.scenario.motor import load_motor
from ltdsim.physics.drive import foc
from ltdsim.physics.drive.induction import (
    MP_LM,
    MP_LR,
    MP_LS,
    MP_P,
    MP_RS,
    breakdown_torque,
    currents,
    equivalent_circuit,
    motor_row,
    torque,
)
from ltdsim.scenario import Scenario
from ltdsim.results.simulate import simulate

PRESET = "study-850kw"
GEAR = 5.02       # the default wheelset's gear ratio (creep_schema.Wheelset)
RADIUS = 0.625    # m, its wheel radius


@pytest.fixture(scope="module")
def drive():
    motor = load_motor(PRESET)
    return motor, motor_row(motor), foc.controller_row(motor)


def _limits(motor, m, c, wm):
    """The drive's torque limits (N m) in closed form from the motor's parameters: the
    current limit at rated flux ``k_t i_d0 sqrt(I_max^2 - i_d0^2)`` and the power limit
    ``P / |w_m|``; and the breakdown torque at the planned voltage (scipy's maximum of
    the phasor circuit over the slip)."""
    kt = 1.5 * m[MP_P] * m[MP_LM] ** 2 / m[MP_LR]
    id0 = foc.rated_flux(motor) / m[MP_LM]
    t_cur = kt * id0 * math.sqrt(c[foc.C_IMAX] ** 2 - id0 ** 2)
    t_pow = motor.rated_power / abs(wm) if wm != 0.0 else math.inf
    vfw = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    # (near standstill the breakdown torque is far beyond the others)
    t_bd = breakdown_torque(m, vfw, abs(wm))[0] if abs(wm) > 1e-3 else math.inf
    return t_cur, t_pow, t_bd


def _state_report(motor, m, c, y, wm, t_ref):
    """Rates and outputs of drive_rates at ``y``; the largest rate over its scale (the
    inverter's voltage limit for the fluxes, Wb/s; K_i I_max for the integrators, V/s)."""
    dy = np.zeros(foc.N_DRIVE)
    out = np.zeros(foc.N_OUT)
    te = foc.drive_rates(y, wm, t_ref, motor.dc_link_voltage, m, c, dy, out)
    scale = np.full(foc.N_DRIVE, motor.dc_link_voltage / math.sqrt(3.0))
    scale[foc.FOC_ID] = scale[foc.FOC_IQ] = c[foc.C_KI] * c[foc.C_IMAX]
    return te, out, float(np.max(np.abs(dy) / scale))


@settings(max_examples=80, deadline=None)
@given(speed=st.floats(0.0, 40.0), load=st.floats(-1.3, 1.3))
def test_the_initial_state_is_an_equilibrium_of_the_drive(speed, load):
    """At any speed 0-40 m/s (on the default gear and wheels) and any demand up to 1.3 x
    the current limit's torque either way, the state drive_steady gives is an
    equilibrium of the drive: every rate of drive_rates vanishes (below 1e-9 of its
    scale); the stator current is within its limit and the voltage within the
    inverter's; the torque and stator current are those of the phasor equivalent
    circuit fed with that voltage at that frequency and slip; the torque has the
    demand's sign and at most its size, and equals a demand within the limits."""
    motor = load_motor(PRESET)
    m, c = motor_row(motor), foc.controller_row(motor)
    wm = GEAR * speed / RADIUS
    t_cur, t_pow, t_bd = _limits(motor, m, c, wm)
    t_ref = load * t_cur
    y = foc.drive_steady(m, c, wm, t_ref, motor.dc_link_voltage)
    te, out, worst = _state_report(motor, m, c, y, wm, t_ref)
    assert worst < 1e-9
    i_d, i_q, _, _ = currents(y, m)
    assert math.hypot(i_d, i_q) <= c[foc.C_IMAX] * (1.0 + 1e-12)
    v = math.hypot(out[foc.O_VD], out[foc.O_VQ])
    assert v <= motor.dc_link_voltage / math.sqrt(3.0) * (1.0 + 1e-12)
    assert te == pytest.approx(torque(y, m), rel=1e-12, abs=1e-9)
    assert te * t_ref >= 0.0 and abs(te) <= abs(t_ref) * (1.0 + 1e-9) + 1e-9
    # a demand well within every limit is delivered
    if abs(t_ref) < 0.9 * min(t_cur, t_pow, motor.breakdown_margin * t_bd):
        assert te == pytest.approx(t_ref, rel=1e-9, abs=1e-9)
    # the phasor circuit at the applied voltage, frequency and slip
    we = out[foc.O_WE]
    if abs(te) > 1.0 and we != 0.0:
        ref = equivalent_circuit(m, v, abs(we), (we - m[MP_P] * wm) / we)
        # (a frame turning backwards is the mirror image: the torque's sign turns)
        assert ref["torque"] * math.copysign(1.0, we) == pytest.approx(te, rel=1e-6)
        assert ref["stator_current"] == pytest.approx(math.hypot(i_d, i_q), rel=1e-6)


@pytest.mark.parametrize("speed", [0.0, 5.0, 16.0, 20.0, 30.0, 40.0])
def test_no_demand_holds_the_flux_the_voltage_allows(drive, speed):
    """No torque demand: the torque is zero and the flux is the rated one where the
    voltage allows it, else the one at which the steady-state stator voltage is the
    planned ``V_fw = voltage_margin V_dc / sqrt(3)``: with no torque current and no
    slip ``|v| = i_d sqrt(R_s^2 + (p w_m L_s)^2)``, so ``i_d = V_fw / sqrt(R_s^2 + (p w_m
    L_s)^2)`` (the voltage equations in closed form)."""
    motor, m, c = drive
    wm = GEAR * speed / RADIUS
    y = foc.drive_steady(m, c, wm, 0.0, motor.dc_link_voltage)
    te, out, worst = _state_report(motor, m, c, y, wm, 0.0)
    assert worst < 1e-9
    assert abs(te) < 1e-9
    i_d, i_q, _, _ = currents(y, m)
    assert abs(i_q) < 1e-9
    vfw = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    id0 = foc.rated_flux(motor) / m[MP_LM]
    expected = min(id0, vfw / math.hypot(m[MP_RS], m[MP_P] * wm * m[MP_LS]))
    assert i_d == pytest.approx(expected, rel=1e-9)
    assert y[foc.FOC_FLUX] == pytest.approx(m[MP_LM] * expected, rel=1e-9)
    if speed >= 20.0:
        assert expected < 0.9 * id0  # these are in field weakening


def test_standstill_without_demand_is_the_magnetised_drive(drive):
    """At standstill with no demand the steady state is drive_init's magnetised drive,
    bit for bit (scenarios starting from rest without demand run as before)."""
    motor, m, c = drive
    y = foc.drive_steady(m, c, 0.0, 0.0, motor.dc_link_voltage)
    assert (y == foc.drive_init(m, c)).all()


# --- in the train ----------------------------------------------------------------------

STATIC = 120000.0  # kg on the six driven axles: 348 kN at 5 m/s is within the dry rail's


def _scenario(speed, *, notch=None, force=None, t_end=0.5):
    """A 1000 t locomotive (120 t on its driven wheels, no resistance) on the induction
    drive at ``speed`` (m/s), under a constant notch or force, every step recorded."""
    driver = ({"mode": "notch", "notch_profile": [[0.0, notch]]} if notch is not None
              else {"mode": "force", "force_profile": [[0.0, force], [t_end, force]]})
    return Scenario.from_dict({
        "solver": {"method": "ode3", "dt": 1e-4, "t_end": t_end, "output_interval": 1e-4},
        "vehicles": [{"name": "loco", "mass": 1.0e6, "static_mass": STATIC,
                      "length": 20.0, "davis": {"a": 0.0, "b": 0.0, "c": 0.0},
                      "powered": True}],
        "traction": {"max_force": 8.63e5, "max_power": 1.443e7, "adhesion_mass": 8.7663e5,
                     "drive": "induction", "creep": {"rail": "dry"}},
        "driver": driver,
        "initial": {"speed": speed}})


def _run(s):
    ds = simulate(s)
    motor = s.traction.motor.motor()
    ws = s.traction.creep.wheelset
    n_m = s.traction.motor.per_locomotive
    return ds, motor, ws, n_m


@pytest.mark.parametrize("speed", [5.0, 20.0, 30.0])
def test_a_start_at_speed_without_demand_has_no_transient(speed):
    """Started at speed with no demand (0.5 s, every 0.1 ms step recorded): no torque, no
    force, and the stator current is the magnetising current of the flux the voltage
    allows (closed form as above), unchanged from the first step to the last."""
    s = _scenario(speed, notch=0)
    ds, motor, ws, n_m = _run(s)
    m = motor_row(motor)
    assert np.abs(ds.motor_torque.values[:, 0]).max() < 1e-6
    assert np.abs(ds.creep_force.values[:, 0]).max() < 1e-3
    vfw = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    id0 = foc.rated_flux(motor) / m[MP_LM]
    wm = ws.gear_ratio * speed / ws.wheel_radius
    i_d = min(id0, vfw / math.hypot(m[MP_RS], m[MP_P] * wm * m[MP_LS]))
    i_rms = i_d / math.sqrt(2.0) / math.sqrt(3.0)  # delta winding
    i = ds.stator_current.values[:, 0]
    assert np.allclose(i, i_rms, rtol=1e-6)


@pytest.mark.parametrize("speed, notch", [(5.0, 8), (20.0, 8), (30.0, 8), (20.0, -8),
                                         (30.0, -8)])
def test_a_start_at_speed_at_full_demand_rises_to_the_limit_without_overshoot(speed, notch):
    """Started at speed in notch 8 or -8 (a demand beyond the drive either way; 0.5 s,
    every step recorded): the stator current never exceeds its limit; the motor torque
    is at the drive's limit (current limit at rated flux, or power over the shaft
    speed; the breakdown limit does not bind at these speeds) at the first step and
    within 0.1 % after it; the creep force never has the opposite sign, never exceeds
    the demand nor what that torque gives through the gear (``motors G eta T / r``
    motoring, ``motors G T / (eta r)`` braking), grows monotonically to its peak as the
    wheels take up creep and then moves by less than 0.1 % of it a step."""
    s = _scenario(speed, notch=notch)
    ds, motor, ws, n_m = _run(s)
    m = motor_row(motor)
    c = foc.controller_row(motor)
    sign = math.copysign(1.0, notch)
    i = ds.stator_current.values[:, 0]
    assert i.max() <= motor.max_current * (1.0 + 1e-9)
    wm = ds.motor_speed.values[:, 0]
    t_cur, _, t_bd = _limits(motor, m, c, wm[0])
    t_lim = np.minimum(t_cur, motor.rated_power / wm)
    assert t_lim[0] < motor.breakdown_margin * t_bd
    tm = sign * ds.motor_torque.values[:, 0]
    # (within the current loops' lag behind the power limit, which moves as the wheels
    # take up creep in the first milliseconds: 0.045 % at most, at 20 m/s)
    assert tm[0] == pytest.approx(t_lim[0], rel=1e-6)
    assert np.allclose(tm, t_lim, rtol=1e-3)
    f = sign * ds.creep_force.values[:, 0]
    demand = sign * float(ds.traction_demand[0])
    gear = ws.gear_ratio * (ws.gear_efficiency if sign > 0 else 1.0 / ws.gear_efficiency)
    f_lim = n_m * gear * t_lim / ws.wheel_radius
    assert f.min() >= 0.0
    assert (f <= np.minimum(demand, f_lim) * (1.0 + 1e-6)).all()
    k = int(np.argmax(f))
    assert f[k] > 0.95 * f_lim[k]  # it gets there
    assert (np.diff(f[:k + 1]) >= -1e-9 * f[k]).all()
    # (braking, the peak is the last step: the power limit's torque grows as the train
    # slows)
    assert (np.abs(np.diff(f[k:])) < 1e-3 * f[k]).all()


def test_a_demand_within_the_limits_is_met_without_overshoot():
    """Started at 20 m/s (field weakening) under a force demand within the drive's
    limits (150 kN, force mode): the motors deliver the demand's torque from the first
    step; the current stays within its limit; the creep force never exceeds the demand,
    rises monotonically until it is within 0.1 % of the demand less what the wheelsets'
    inertia takes as the train accelerates (``motors J a / r^2``, with the recorded
    acceleration ``a``) and stays within 0.1 % of that."""
    demand = 1.5e5
    s = _scenario(20.0, force=demand)
    ds, motor, ws, n_m = _run(s)
    t_dem = demand * ws.wheel_radius / (n_m * ws.gear_ratio * ws.gear_efficiency)
    assert float(ds.motor_torque[0, 0]) == pytest.approx(t_dem, rel=1e-9)
    assert ds.stator_current.values[:, 0].max() <= motor.max_current * (1.0 + 1e-9)
    f = ds.creep_force.values[:, 0]
    j = ws.inertia + ws.gear_ratio ** 2 * motor.rotor_inertia
    f_exp = demand - n_m * j * ds.acceleration.values[:, 0] / ws.wheel_radius ** 2
    assert f.min() >= 0.0
    assert f.max() <= demand
    near = np.abs(f - f_exp) <= 1e-3 * demand
    k = int(np.argmax(near))
    assert near[k] and near[k:].all()
    assert (np.diff(f[:k + 1]) >= 0.0).all()


@pytest.mark.parametrize("speed", [5.0, 20.0, 30.0])
def test_speed_mode_at_speed_follows_the_controller_within_the_limits(speed):
    """The study's train on the drive (paper-induction.toml) started at speed with its
    reference held there (speed mode, 1 s): lowering does not evaluate the speed
    controller's first output, so the drive starts in the steady state of no torque and
    the current loops follow the controller's demand (the resistance's feed-forward and
    the PID's answer to the speed error) from there: the current stays within its limit
    and the creep force never has the opposite sign of the demand (the force lags the
    PID's changing demand, so it is not bounded by it step by step)."""
    from pathlib import Path

    from ltdsim.scenario import load_scenario

    root = Path(__file__).resolve().parents[2] / "scenarios"
    s = load_scenario(root / "paper-induction.toml").with_overrides(
        {"solver.t_end": 1.0, "solver.output_interval": 1e-4, "initial.speed": speed,
         "driver.speed_profile": [[0.0, speed], [100.0, speed]]})
    ds = simulate(s)
    motor = s.traction.motor.motor()
    assert ds.stator_current.values[:, 0].max() <= motor.max_current * (1.0 + 1e-9)
    f = ds.creep_force.values[:, 0]
    demand = ds.traction_demand.values
    assert (demand > 0.0).all()
    assert f.min() >= 0.0


def test_each_consist_starts_at_its_share_of_the_demand():
    """Three locomotives on the drive at 20 m/s: two follow the driver's force (150 kN,
    shared in proportion to their max_force, 600 and 300 kN), the third runs its own
    notch 4 (half its traction curve at the speed, ``min(F_max, P_max / v,
    adhesion)``). Each one's motors deliver, from the first step, the torque of its
    demand (``demand r / (motors G eta)``, all within the drive's limits)."""
    from ltdsim.physics.drive.traction import traction_max

    veh = [{"name": f"loco{k}", "mass": 1.0e6, "static_mass": STATIC, "length": 20.0,
            "davis": {"a": 0.0, "b": 0.0, "c": 0.0}, "powered": True} for k in range(3)]
    s = Scenario.from_dict({
        "solver": {"method": "ode3", "dt": 1e-4, "t_end": 0.01, "output_interval": 1e-4},
        "vehicles": veh,
        "couplers": {"default": {"model": "linear", "stiffness": 5e7, "damping": 5e5}},
        "traction": {"max_force": 8.63e5, "max_power": 1.443e7, "adhesion_mass": 8.7663e5,
                     "drive": "induction", "creep": {"rail": "dry"}},
        "locomotives": [{"name": "a", "vehicles": [0], "max_force": 6e5},
                        {"name": "b", "vehicles": [1], "max_force": 3e5},
                        {"name": "c", "vehicles": [2], "max_force": 3e5,
                         "notch_profile": [[0.0, 4]]}],
        "driver": {"mode": "force", "force_profile": [[0.0, 1.5e5], [1.0, 1.5e5]]},
        "initial": {"speed": 20.0}})
    ds = simulate(s)
    ws = s.traction.creep.wheelset
    n_m = s.traction.motor.per_locomotive
    curve = traction_max(20.0, 3e5, 1.443e7, 8.7663e5, s.track.gravity)
    demands = [1.5e5 * 2 / 3, 1.5e5 / 3, 0.5 * curve]
    for k, dem in enumerate(demands):
        t_dem = dem * ws.wheel_radius / (n_m * ws.gear_ratio * ws.gear_efficiency)
        assert float(ds.motor_torque[0, k]) == pytest.approx(t_dem, rel=1e-9)
        assert t_dem < 0.9 * s.traction.motor.motor().rated_power / float(
            ds.motor_speed[0, k])
