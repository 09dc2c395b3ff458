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

from ltdsim.drive_schema import load_motor
from ltdsim.physics import foc
from ltdsim.physics.induction import (
    M_LM,
    M_LR,
    M_LS,
    M_P,
    M_RS,
    breakdown_torque,
    currents,
    equivalent_circuit,
    motor_row,
    torque,
)

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
    kt = 1.5 * m[M_P] * m[M_LM] ** 2 / m[M_LR]
    id0 = foc.rated_flux(motor) / m[M_LM]
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
    scale[foc.S_ID] = scale[foc.S_IQ] = c[foc.C_KI] * c[foc.C_IMAX]
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
        ref = equivalent_circuit(m, v, abs(we), (we - m[M_P] * wm) / we)
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
    id0 = foc.rated_flux(motor) / m[M_LM]
    expected = min(id0, vfw / math.hypot(m[M_RS], m[M_P] * wm * m[M_LS]))
    assert i_d == pytest.approx(expected, rel=1e-9)
    assert y[foc.S_FLUX] == pytest.approx(m[M_LM] * expected, rel=1e-9)
    if speed >= 20.0:
        assert expected < 0.9 * id0  # these are in field weakening


def test_standstill_without_demand_is_the_magnetised_drive(drive):
    """At standstill with no demand the steady state is drive_init's magnetised drive,
    bit for bit (scenarios starting from rest without demand run as before)."""
    motor, m, c = drive
    y = foc.drive_steady(m, c, 0.0, 0.0, motor.dc_link_voltage)
    assert (y == foc.drive_init(m, c)).all()
