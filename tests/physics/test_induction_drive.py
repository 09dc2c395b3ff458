"""The induction traction drive: machine model, field-oriented control, inverter limit.

Each check compares the compiled laws (``ltdsim.physics.drive.induction``, ``ltdsim.physics.drive.foc``)
with something independent: the machine's equivalent circuit solved with complex phasors,
the first-order response the current-loop design promises, the study's ratings, and the
power balance of the machine, integrated by scipy's ``solve_ivp`` (not the project's
integrators).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from ltdsim.data import preset_names
from ltdsim.scenario.motor import Motor, load_motor
from ltdsim.physics.drive import foc
from ltdsim.physics.drive.induction import (
    MP_LM,
    MP_LR,
    MP_P,
    MP_RR,
    N_MOTOR,
    breakdown_torque,
    copper_loss,
    currents,
    derive_from_ratings,
    equivalent_circuit,
    machine_rates,
    magnetic_energy,
    motor_row,
    torque,
)

RPM = math.pi / 30.0  # rad/s per rpm
PRESET = "study-850kw"


@pytest.fixture(scope="module")
def drive():
    motor = load_motor(PRESET)
    return motor, motor_row(motor), foc.controller_row(motor)


def _winding_rms(i_peak, motor):
    """Winding current, A rms, of a peak line current (A)."""
    return i_peak / math.sqrt(2.0) / (math.sqrt(3.0) if motor.connection == "delta" else 1.0)


def _dq_steady_state(m, vd, vq, we, wr):
    """Flux linkages where the machine's rates vanish: the rates are affine in the
    fluxes at fixed voltage and speeds, so one linear solve finds the steady state."""
    ds = np.zeros(N_MOTOR)
    zero = np.zeros(N_MOTOR)
    machine_rates(zero, vd, vq, we, wr, m, ds)
    b = ds.copy()
    a = np.zeros((N_MOTOR, N_MOTOR))
    for j in range(N_MOTOR):
        e = np.zeros(N_MOTOR)
        e[j] = 1.0
        machine_rates(e, vd, vq, we, wr, m, ds)
        a[:, j] = ds - b
    return np.linalg.solve(a, -b)


def _fixed_speed(motor, m, c, n_rpm, t_ref, t_end, y0=None, **kw):
    """The drive at a constant shaft speed (rpm) and torque demand (N m), from the
    magnetised state (or ``y0``), integrated by solve_ivp (Radau)."""
    wm = n_rpm * RPM
    dy = np.zeros(foc.N_DRIVE)
    out = np.zeros(foc.N_OUT)
    tr = t_ref if callable(t_ref) else (lambda t: t_ref)

    def f(t, y):
        foc.drive_rates(y, wm, tr(t), motor.dc_link_voltage, m, c, dy, out)
        return dy.copy()

    y0 = foc.drive_init(m, c) if y0 is None else y0
    return solve_ivp(f, (0.0, t_end), y0, method="Radau", **kw)


def _outputs(motor, m, c, y, wm, t_ref):
    dy = np.zeros(foc.N_DRIVE)
    out = np.zeros(foc.N_OUT)
    foc.drive_rates(y, wm, t_ref, motor.dc_link_voltage, m, c, dy, out)
    return out


# --- parameters -----------------------------------------------------------------------

def test_preset_is_the_derivation_from_the_ratings():
    """The shipped circuit is what the documented method gives from the ratings (to the
    5 significant digits written), and the set reproduces the ratings: 850 kW and 270 A
    winding at 1283 rpm, within the DC link's voltage limit."""
    assert PRESET in preset_names("motors")
    motor = load_motor(PRESET)
    d = derive_from_ratings(motor)
    for key in ("stator_resistance", "rotor_resistance", "stator_leakage_inductance",
                "rotor_leakage_inductance", "magnetising_inductance"):
        assert getattr(motor, key) == pytest.approx(d[key], rel=5e-5), key
    m = motor_row(motor)
    wb = motor.base_speed * RPM
    we = motor.pole_pairs * wb / (1.0 - motor.rated_slip)
    v = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    assert v < motor.dc_link_voltage / math.sqrt(3.0)
    c = equivalent_circuit(m, v, we, motor.rated_slip)
    assert c["torque"] * c["shaft_speed"] == pytest.approx(850.0e3, rel=1e-3)
    assert c["shaft_speed"] == pytest.approx(1283.0 * RPM, rel=1e-12)
    assert _winding_rms(c["stator_current"], motor) == pytest.approx(270.0, rel=1e-3)
    # the power factor the delta reading implies, and an efficiency without iron loss
    assert 0.7 < c["power_factor"] < 0.8
    assert 0.95 < c["torque"] * c["shaft_speed"] / c["input_power"] < 0.99


def test_motor_schema_refuses_bad_values():
    motor = load_motor(PRESET)
    data = motor.model_dump()
    with pytest.raises(ValueError, match="max_speed"):
        Motor(**{**data, "max_speed": 1000.0})
    with pytest.raises(ValueError, match="max_current"):
        Motor(**{**data, "max_current": 200.0})
    with pytest.raises(ValueError):
        Motor(**{**data, "pole_pairs": 2.0})  # strict: an integer must be an integer
    with pytest.raises(ValueError):
        Motor(**{**data, "unknown_key": 1.0})


def test_bad_motor_preset_is_one_line_naming_file_and_key(tmp_path, monkeypatch):
    import ltdsim.data as data
    import ltdsim.scenario.motor as ds

    text = data._folder("motors").joinpath(f"{PRESET}.toml").read_text(encoding="utf-8")
    bad = text.replace("rotor_resistance = 0.020563", "rotor_resistance = -0.02")
    assert bad != text
    (tmp_path / "motors").mkdir()
    (tmp_path / "motors" / "broken.toml").write_text(bad, encoding="utf-8")
    monkeypatch.setattr(data, "_folder", lambda family: tmp_path / family)
    for cached in (data.preset_names, data._read):
        cached.cache_clear()
    monkeypatch.setattr(data, "preset_names", data.preset_names.__wrapped__)
    monkeypatch.setattr(data, "_read", data._read.__wrapped__)
    with pytest.raises(ValueError) as e:
        ds.load_motor("broken")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("broken.toml: rotor_resistance:"), msg
    with pytest.raises(ValueError, match="unknown motor preset 'nope'; available: broken"):
        ds.load_motor("nope")


# --- machine model against the equivalent circuit -------------------------------------

@pytest.mark.parametrize("slip", [-0.05, -0.01, 0.002, 0.01, 0.03, 0.1, 0.4, 1.0])
def test_steady_state_matches_equivalent_circuit(drive, slip):
    """Torque and stator current of the dq model's steady state (rates zero, in the
    synchronous frame) against the T-circuit solved with phasors, at the rated voltage
    and frequency: motoring, generating, standstill (slip 1)."""
    motor, m, _ = drive
    v = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    we = 2.0 * math.pi * 43.2
    wr = we * (1.0 - slip)
    s = _dq_steady_state(m, v, 0.0, we, wr)
    isd, isq, _, _ = currents(s, m)
    ref = equivalent_circuit(m, v, we, slip)
    assert torque(s, m) == pytest.approx(ref["torque"], rel=5e-3)
    assert math.hypot(isd, isq) == pytest.approx(ref["stator_current"], rel=5e-3)


@settings(max_examples=60, deadline=None)
@given(slip=st.floats(-1.0, 1.0).filter(lambda s: abs(s) > 1e-4),
       freq=st.floats(2.0, 100.0), v=st.floats(50.0, 1260.0))
def test_steady_state_matches_circuit_over_ranges(slip, freq, v):
    motor = load_motor(PRESET)
    m = motor_row(motor)
    we = 2.0 * math.pi * freq
    s = _dq_steady_state(m, 0.0, v, we, we * (1.0 - slip))  # voltage on the q axis
    isd, isq, _, _ = currents(s, m)
    ref = equivalent_circuit(m, v, we, slip)
    assert torque(s, m) == pytest.approx(ref["torque"], rel=5e-3, abs=1e-9)
    assert math.hypot(isd, isq) == pytest.approx(ref["stator_current"], rel=5e-3)


def test_dynamic_model_settles_to_the_circuit(drive):
    """Started unmagnetised on a fixed supply (rated voltage and frequency, 2 % slip),
    the integrated dq model settles to the circuit's torque and current."""
    motor, m, _ = drive
    v = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    we = 2.0 * math.pi * 43.2
    slip = 0.02
    ds = np.zeros(N_MOTOR)

    def f(t, s):
        machine_rates(s, v, 0.0, we, we * (1.0 - slip), m, ds)
        return ds.copy()

    sol = solve_ivp(f, (0.0, 3.0), np.zeros(N_MOTOR), method="Radau", rtol=1e-8,
                    atol=1e-8)
    s = sol.y[:, -1]
    isd, isq, _, _ = currents(s, m)
    ref = equivalent_circuit(m, v, we, slip)
    assert torque(s, m) == pytest.approx(ref["torque"], rel=5e-3)
    assert math.hypot(isd, isq) == pytest.approx(ref["stator_current"], rel=5e-3)


# --- controller ---------------------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(speed=st.floats(1.05, 2.2), load=st.floats(0.05, 1.0))
def test_field_weakening_law_against_the_circuit(speed, load):
    """The field-weakening flux current (the quadratic in the controller) against the
    phasor circuit: at the frequency, torque and flux current it gives, with the torque
    current and slip of field orientation, the circuit fed with the planned voltage
    carries that torque and that current. Speeds 1.05-2.2 x base, torques up to the
    drive's limit there."""
    motor = load_motor(PRESET)
    m = motor_row(motor)
    c = foc.controller_row(motor)
    p, lm, lr, rr = m[MP_P], m[MP_LM], m[MP_LR], m[MP_RR]
    kt = 1.5 * p * lm * lm / lr
    vfw = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    wm = speed * motor.base_speed * RPM
    t = load * min(motor.rated_power / wm,
                   0.8 * motor.breakdown_margin * breakdown_torque(m, vfw, wm)[0])
    # the slip depends on i_d: iterate the frame frequency to the fixed point
    we = p * wm
    for _ in range(50):
        i_d = foc._flux_current(t, we, vfw, c)
        i_q = t / (kt * i_d)
        we_new = p * wm + rr * i_q / (lr * i_d)
        if abs(we_new - we) < 1e-12 * we:
            break
        we = we_new
    assume(i_d < c[foc.C_PSI0] / lm * (1.0 - 1e-6))  # field weakening active
    ref = equivalent_circuit(m, vfw, we, (we - p * wm) / we)
    assert ref["torque"] == pytest.approx(t, rel=5e-3)
    assert ref["stator_current"] == pytest.approx(math.hypot(i_d, i_q), rel=5e-3)



def test_torque_step_follows_the_current_loop_design(drive):
    """A torque step at 300 rpm (far below base speed, no voltage limit): the designed
    loops are first-order lags of the bandwidth w_c, so the torque is T (1 - exp(-w_c t))
    and settles to 2 % in ln(50)/w_c (6.2 ms at 100 Hz)."""
    motor, m, c = drive
    t_step = 3000.0
    wc = 2.0 * math.pi * motor.current_bandwidth
    t = np.linspace(0.0, 0.03, 301)
    sol = _fixed_speed(motor, m, c, 300.0, t_step, 0.03, t_eval=t, rtol=1e-9, atol=1e-9)
    te = np.array([torque(sol.y[:N_MOTOR, k], m) for k in range(t.size)])
    expected = t_step * (1.0 - np.exp(-wc * t))
    assert np.max(np.abs(te - expected)) < 0.005 * t_step
    outside = np.nonzero(np.abs(te - t_step) > 0.02 * t_step)[0]
    settle = t[outside[-1] + 1]
    assert settle == pytest.approx(math.log(50.0) / wc, abs=0.2e-3)
    # the flux stays at its reference through the step (decoupled loops)
    psi = np.hypot(sol.y[2], sol.y[3])
    assert np.max(np.abs(psi / c[foc.C_PSI0] - 1.0)) < 1e-3


def test_flux_at_reference_below_base_and_field_weakening_above(drive):
    """At rated torque the drive holds the rated flux up to base speed; above it the flux
    follows the field-weakening reference, which falls with speed, and the steady voltage
    is the planned fraction of the DC link's limit. Base speed is not an input of the
    controller: it comes out of the parameters at 1283 rpm (within 3 %)."""
    motor, m, c = drive
    psi0 = c[foc.C_PSI0]
    t_rated = motor.rated_torque
    vmax = motor.dc_link_voltage / math.sqrt(3.0)
    fluxes = []
    for n in (600.0, 0.97 * motor.base_speed, 1.03 * motor.base_speed, 1800.0,
              motor.max_speed):
        sol = _fixed_speed(motor, m, c, n, t_rated, 4.0, rtol=1e-7, atol=1e-7)
        y = sol.y[:, -1]
        o = _outputs(motor, m, c, y, n * RPM, t_rated)
        psi = math.hypot(y[2], y[3])
        assert psi == pytest.approx(o[foc.O_PSIREF], rel=5e-3), n
        v = math.hypot(o[foc.O_VD], o[foc.O_VQ])
        assert v <= vmax * (1.0 + 1e-9)
        tq = o[foc.O_TREF]
        assert o[foc.O_T] == pytest.approx(tq, rel=5e-3)
        if n < motor.base_speed:
            assert psi == pytest.approx(psi0, rel=5e-3), n
            assert tq == pytest.approx(t_rated, rel=1e-9)
        else:
            assert psi < psi0 * 0.995, n
            assert v == pytest.approx(motor.voltage_margin * vmax, rel=5e-3), n
            # above base speed the rated torque is more than rated power: the power
            # limit holds the drive at 850 kW, all the way to maximum speed
            assert o[foc.O_T] * n * RPM == pytest.approx(motor.rated_power, rel=5e-3), n
        fluxes.append(psi)
    assert fluxes[2] > fluxes[3] > fluxes[4]


def test_rated_power_at_maximum_speed(drive):
    """With the demand above every limit, at 2484 rpm the drive delivers 850 kW."""
    motor, m, c = drive
    sol = _fixed_speed(motor, m, c, motor.max_speed, 1e5, 4.0, rtol=1e-7, atol=1e-7)
    o = _outputs(motor, m, c, sol.y[:, -1], motor.max_speed * RPM, 1e5)
    assert o[foc.O_T] * motor.max_speed * RPM == pytest.approx(850.0e3, rel=5e-3)
    assert _winding_rms(math.hypot(o[foc.O_ID], o[foc.O_IQ]), motor) <= motor.max_current


@pytest.mark.parametrize("n_rpm", [1283.0, 1800.0, 2484.0])
def test_dynamic_braking_at_full_demand(drive, n_rpm):
    """Braking (negative torque demand beyond every limit) from base to maximum speed:
    850 kW taken from the shaft, flux on its reference, voltage within the limit, and the
    DC link receives the shaft power less the copper loss (steady state: no stored
    energy change)."""
    motor, m, c = drive
    sol = _fixed_speed(motor, m, c, n_rpm, -1e5, 4.0, rtol=1e-7, atol=1e-7)
    y = sol.y[:, -1]
    o = _outputs(motor, m, c, y, n_rpm * RPM, -1e5)
    p_shaft = o[foc.O_T] * n_rpm * RPM
    assert p_shaft == pytest.approx(-motor.rated_power, rel=5e-3)
    assert math.hypot(y[2], y[3]) == pytest.approx(o[foc.O_PSIREF], rel=5e-3)
    assert math.hypot(o[foc.O_VD], o[foc.O_VQ]) <= motor.dc_link_voltage / math.sqrt(3.0)
    assert o[foc.O_PDC] == pytest.approx(p_shaft + copper_loss(y[:N_MOTOR], m), rel=5e-3)


# --- a start: voltage limit, current limit, energy ---------------------------------------

@pytest.fixture(scope="module")
def start(drive):
    """Start from standstill to past maximum speed under full demand, on a shaft whose
    inertia stands for the train (1000 kg m^2), with the energies integrated alongside:
    DC energy, shaft work, copper loss (J)."""
    motor, m, c = drive
    j_load = 1000.0
    t_ref = 1e5
    dy = np.zeros(foc.N_DRIVE)
    out = np.zeros(foc.N_OUT)
    n = foc.N_DRIVE

    def f(t, x):
        y = x[:n]
        wm = x[n]
        te = foc.drive_rates(y, wm, t_ref, motor.dc_link_voltage, m, c, dy, out)
        return np.concatenate((dy, [te / j_load, out[foc.O_PDC], te * wm,
                                    copper_loss(y, m)]))

    x0 = np.concatenate((foc.drive_init(m, c), np.zeros(4)))
    t_eval = np.linspace(0.0, 60.0, 601)
    sol = solve_ivp(f, (0.0, 60.0), x0, method="Radau", t_eval=t_eval, rtol=1e-8,
                    atol=1e-6)
    assert sol.success
    outs = np.empty((t_eval.size, foc.N_OUT))
    for k in range(t_eval.size):
        outs[k] = _outputs(motor, m, c, sol.y[:n, k], sol.y[n, k], t_ref)
    return sol, outs


def test_start_keeps_voltage_and_current_within_limits(drive, start):
    motor, _, _ = drive
    sol, outs = start
    vmax = motor.dc_link_voltage / math.sqrt(3.0)
    v = np.hypot(outs[:, foc.O_VD], outs[:, foc.O_VQ])
    assert v.max() <= vmax * (1.0 + 1e-9)
    i_w = _winding_rms(np.hypot(outs[:, foc.O_ID], outs[:, foc.O_IQ]), motor)
    assert i_w.max() <= motor.max_current * 1.005
    n_end = sol.y[foc.N_DRIVE, -1] / RPM
    assert n_end > motor.max_speed  # the start reaches top speed
    p = outs[:, foc.O_T] * sol.y[foc.N_DRIVE]
    assert p.max() <= motor.rated_power * 1.005


def test_energy_balance_over_a_start(drive, start):
    """DC energy = shaft work + copper loss + stored magnetic energy's change, to 0.5 %
    (the machine has no other loss; the inverter is lossless)."""
    _, m, _ = drive
    sol, _ = start
    n = foc.N_DRIVE
    e_dc, e_mech, e_cu = sol.y[n + 1, -1], sol.y[n + 2, -1], sol.y[n + 3, -1]
    dw = magnetic_energy(sol.y[:N_MOTOR, -1], m) - magnetic_energy(sol.y[:N_MOTOR, 0], m)
    assert e_dc > 1e7  # tens of MJ: a real start
    assert e_mech + e_cu + dw == pytest.approx(e_dc, rel=5e-3)
    # and the balance holds along the way, not only at the end
    for k in (100, 300):
        dwk = magnetic_energy(sol.y[:N_MOTOR, k], m) - magnetic_energy(sol.y[:N_MOTOR, 0], m)
        assert sol.y[n + 2, k] + sol.y[n + 3, k] + dwk == pytest.approx(sol.y[n + 1, k],
                                                                         rel=5e-3)

