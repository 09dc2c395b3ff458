"""The three-phase squirrel-cage induction machine: the dq model with flux linkages as states.

The machine is the standard two-axis (Park) model of a symmetric three-phase machine with
a sinusoidally distributed winding, linear magnetics and no iron loss (Krause,
Wasynczuk, Sudhoff, *Analysis of Electric Machinery and Drive Systems*, 2nd ed., 2002,
ch. 4; Novotny and Lipo, *Vector Control and Dynamics of AC Drives*, 1996, ch. 5),
written in a reference frame that turns at the electrical angular speed ``w_e`` (rad/s),
motor convention, amplitude-invariant transformation (a dq vector's length is the peak
of the phase quantity), star-equivalent phase quantities::

    d psi_s / dt = v_s - R_s i_s - w_e J psi_s
    d psi_r / dt =     - R_r i_r - (w_e - w_r) J psi_r          (short-circuited cage)
    psi_s = L_s i_s + L_m i_r,   psi_r = L_m i_s + L_r i_r
    T_e   = 3/2 p (psi_sd i_sq - psi_sq i_sd)

with ``J (d, q) = (-q, d)``, ``L_s = L_ls + L_m``, ``L_r = L_lr + L_m`` (H), the rotor's
electrical speed ``w_r = p w_m`` (``p`` pole pairs, ``w_m`` the shaft speed in rad/s,
which comes from outside: the wheelset), stator and rotor flux linkages ``psi`` (Wb),
currents ``i`` (A, peak), voltages ``v`` (V, peak phase) and torque ``T_e`` (N m). The
frame speed ``w_e`` is free: the field-oriented controller (:mod:`ltdsim.physics.drive.foc`)
supplies it so that the rotor flux lies on the d axis.

The power balance the model satisfies exactly (each term W)::

    3/2 (v_sd i_sd + v_sq i_sq) = T_e w_m + 3/2 (R_s |i_s|^2 + R_r |i_r|^2) + dW/dt,
    W = 3/4 (psi_s . i_s + psi_r . i_r)                 (stored magnetic energy, J)

Iron loss, friction and windage are not modelled: no published loss split exists for
the study's motor (its windage and bearing friction belong with the wheelset's
resistance, if anywhere). Saturation is not modelled (the magnetising inductance is
that of the rated flux).

A machine is a float64 parameter row (:data:`MOTOR_PARAMS`), built from a
:class:`ltdsim.scenario.motor.Motor` by :func:`motor_row`; its four states are
:data:`MOTOR_STATES`. The steady state of the model at a given supply is the
equivalent circuit (:func:`equivalent_circuit`), solved with complex phasors; the
parameter set of the study's motor is derived from its ratings by
:func:`derive_from_ratings`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

MOTOR_STATES = (
    "psi_sd",   # stator flux linkage, d axis, Wb
    "psi_sq",   # stator flux linkage, q axis, Wb
    "psi_rd",   # rotor flux linkage, d axis, Wb
    "psi_rq",   # rotor flux linkage, q axis, Wb
)
N_MOTOR = len(MOTOR_STATES)
(IM_PSD, IM_PSQ, IM_PRD, IM_PRQ) = range(N_MOTOR)

MOTOR_PARAMS = (
    "pole_pairs",               # -
    "stator_resistance",        # R_s, ohm (star-equivalent phase)
    "rotor_resistance",         # R_r, ohm (referred to the stator)
    "stator_inductance",        # L_s = L_ls + L_m, H
    "rotor_inductance",         # L_r = L_lr + L_m, H
    "magnetising_inductance",   # L_m, H
)
N_MOTOR_PARAMS = len(MOTOR_PARAMS)
(MP_P, MP_RS, MP_RR, MP_LS, MP_LR, MP_LM) = range(N_MOTOR_PARAMS)


@njit(cache=True, forceinline=True)
def currents(s, par):
    """Stator and rotor currents ``(i_sd, i_sq, i_rd, i_rq)``, A (peak), of the flux
    linkages ``s`` (:data:`MOTOR_STATES`, Wb): the inverse of the inductance matrix."""
    ls = par[MP_LS]
    lr = par[MP_LR]
    lm = par[MP_LM]
    det = ls * lr - lm * lm
    isd = (lr * s[IM_PSD] - lm * s[IM_PRD]) / det
    isq = (lr * s[IM_PSQ] - lm * s[IM_PRQ]) / det
    ird = (ls * s[IM_PRD] - lm * s[IM_PSD]) / det
    irq = (ls * s[IM_PRQ] - lm * s[IM_PSQ]) / det
    return isd, isq, ird, irq


@njit(cache=True, forceinline=True)
def machine_rates(s, vd, vq, we, wr, par, ds):
    """Rates of the machine's flux linkages; returns the electromagnetic torque.

    Parameters
    ----------
    s : float64 array (N_MOTOR)
        Flux linkages :data:`MOTOR_STATES`, Wb.
    vd, vq : float
        Stator voltage in the frame, V (peak phase).
    we : float
        Angular speed of the frame, rad/s (electrical).
    wr : float
        Electrical angular speed of the rotor, ``p w_m``, rad/s.
    par : float64 array (N_MOTOR_PARAMS)
        The machine, :data:`MOTOR_PARAMS`.
    ds : float64 array (N_MOTOR)
        Written: the rates, Wb/s (= V).

    Returns
    -------
    float
        Electromagnetic torque on the rotor, N m (positive motoring for ``w_m > 0``).
    """
    isd, isq, ird, irq = currents(s, par)
    ds[IM_PSD] = vd - par[MP_RS] * isd + we * s[IM_PSQ]
    ds[IM_PSQ] = vq - par[MP_RS] * isq - we * s[IM_PSD]
    ds[IM_PRD] = -par[MP_RR] * ird + (we - wr) * s[IM_PRQ]
    ds[IM_PRQ] = -par[MP_RR] * irq - (we - wr) * s[IM_PRD]
    return 1.5 * par[MP_P] * (s[IM_PSD] * isq - s[IM_PSQ] * isd)


@njit(cache=True)
def torque(s, par):
    """Electromagnetic torque ``3/2 p (psi_sd i_sq - psi_sq i_sd)``, N m."""
    isd, isq, _, _ = currents(s, par)
    return 1.5 * par[MP_P] * (s[IM_PSD] * isq - s[IM_PSQ] * isd)


@njit(cache=True)
def copper_loss(s, par):
    """Stator and rotor copper loss ``3/2 (R_s |i_s|^2 + R_r |i_r|^2)``, W."""
    isd, isq, ird, irq = currents(s, par)
    return 1.5 * (par[MP_RS] * (isd * isd + isq * isq) + par[MP_RR] * (ird * ird + irq * irq))


@njit(cache=True)
def magnetic_energy(s, par):
    """Magnetic energy stored in the machine's inductances ``3/4 (psi_s.i_s + psi_r.i_r)``,
    J (the 3/2 of the amplitude-invariant transformation times 1/2 i^T L i)."""
    isd, isq, ird, irq = currents(s, par)
    return 0.75 * (s[IM_PSD] * isd + s[IM_PSQ] * isq + s[IM_PRD] * ird + s[IM_PRQ] * irq)


# --- set-up in Python: parameter row, closed form, derivation from ratings ---------------

def motor_row(motor) -> np.ndarray:
    """The machine's parameter row (:data:`MOTOR_PARAMS`, float64) from a
    :class:`ltdsim.scenario.motor.Motor`."""
    row = np.zeros(N_MOTOR_PARAMS)
    row[MP_P] = motor.pole_pairs
    row[MP_RS] = motor.stator_resistance
    row[MP_RR] = motor.rotor_resistance
    row[MP_LM] = motor.magnetising_inductance
    row[MP_LS] = motor.stator_leakage_inductance + motor.magnetising_inductance
    row[MP_LR] = motor.rotor_leakage_inductance + motor.magnetising_inductance
    return row


def equivalent_circuit(par: np.ndarray, v_peak: float, we: float, slip: float) -> dict:
    """Steady state of the machine fed with a balanced sinusoidal voltage: the per-phase
    T equivalent circuit solved with complex phasors (amplitude-invariant, peak values).

    ``Z = R_s + j we L_ls + (j we L_m) || (R_r / slip + j we L_lr)``, ``I_s = V / Z``,
    ``I_r = I_s j we L_m / (R_r / slip + j we L_r)``; the air-gap power
    ``3/2 |I_r|^2 R_r / slip`` drives the torque ``T = p 3/2 |I_r|^2 R_r / (slip we)``.

    Parameters: the machine row, the stator voltage amplitude (V, peak phase), the supply's
    angular frequency (rad/s, electrical, > 0) and the slip ``(we - p w_m) / we`` (-, != 0).
    Returns a dict: ``torque`` N m, ``stator_current`` A peak, ``rotor_current`` A peak,
    ``input_power`` W, ``power_factor`` -, ``shaft_speed`` rad/s, ``rotor_flux`` Wb peak.
    """
    p = par[MP_P]
    lm = par[MP_LM]
    lls = par[MP_LS] - lm
    llr = par[MP_LR] - lm
    zr = par[MP_RR] / slip + 1j * we * llr
    zm = 1j * we * lm
    z = par[MP_RS] + 1j * we * lls + zm * zr / (zm + zr)
    i_s = v_peak / z
    i_r = -i_s * zm / (zm + zr)        # rotor current, same sign convention as the dq model
    t = 1.5 * p * abs(i_r) ** 2 * par[MP_RR] / (slip * we)
    psi_r = lm * i_s + (llr + lm) * i_r
    return {
        "torque": t,
        "stator_current": abs(i_s),
        "rotor_current": abs(i_r),
        "input_power": 1.5 * (v_peak * np.conj(i_s)).real,
        "power_factor": math.cos(np.angle(i_s)),
        "shaft_speed": we * (1.0 - slip) / p,
        "rotor_flux": abs(psi_r),
    }


def line_current_peak(current_rms: float, connection: str) -> float:
    """Peak star-equivalent phase (line) current, A, of a winding current ``current_rms``
    (A rms): times sqrt(3) for a delta-connected stator, times sqrt(2) for the peak."""
    return current_rms * (math.sqrt(3.0) if connection == "delta" else 1.0) * math.sqrt(2.0)


def breakdown_torque(par: np.ndarray, v_peak: float, wm: float) -> tuple[float, float]:
    """Largest steady motoring torque of the machine at shaft speed ``wm`` (rad/s, > 0)
    fed with the voltage amplitude ``v_peak`` (V): the maximum over the slip of
    :func:`equivalent_circuit` (the frequency follows the slip at the given speed).
    Returns ``(torque N m, slip -)``."""
    from scipy.optimize import minimize_scalar

    p = par[MP_P]

    def neg(log_slip):
        s = math.exp(log_slip)
        return -equivalent_circuit(par, v_peak, p * wm / (1.0 - s), s)["torque"]

    res = minimize_scalar(neg, bounds=(math.log(1e-5), math.log(0.5)), method="bounded",
                          options={"xatol": 1e-10})
    return -res.fun, math.exp(res.x)


def derive_from_ratings(motor, tol: float = 1e-12) -> dict:
    """Equivalent-circuit parameters of a motor from its ratings (ltdsim's method).

    From the ratings (rated power ``P`` W at base speed ``n_b`` rpm, maximum speed
    ``n_max`` rpm, DC-link voltage ``V_dc`` V, rated winding current A rms, stator
    connection, pole pairs) and four design figures (rated slip, stator copper loss as a
    fraction of ``P``, the voltage margin and the breakdown margin), the method fixes:

    1. the phase voltage at the rated point, ``margin V_dc / sqrt(3)`` (V peak): the
       rated point is reached at base speed with the inverter's space-vector limit less a
       margin for the current controllers;
    2. ``R_s`` from the stator copper loss at rated current;
    3. ``L_ls = L_lr`` (the usual equal split of the leakage);
    4. ``L_m``, the leakage and ``R_r`` from three conditions solved together: at the
       rated slip and base speed the equivalent circuit gives the rated torque
       ``P / w_b`` and the rated current; and the breakdown torque at maximum speed, times
       the breakdown margin, equals ``P / w_max`` (the rated power is available up to the
       maximum speed: the constant-power range the two rated speeds describe).

    ``motor`` has the attributes of :class:`ltdsim.scenario.motor.Motor` (the circuit values
    it carries are not used). Returns a dict with ``stator_resistance``,
    ``rotor_resistance``, ``stator_leakage_inductance``, ``rotor_leakage_inductance``,
    ``magnetising_inductance`` (ohm, H) and ``rated_frequency`` (Hz),
    ``power_factor`` (-), ``rotor_flux`` (Wb peak) of the rated point.
    """
    from scipy.optimize import fsolve

    p = motor.pole_pairs
    wb = motor.base_speed * math.pi / 30.0
    wmax = motor.max_speed * math.pi / 30.0
    v = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    i_rated = line_current_peak(motor.rated_current, motor.connection)
    t_rated = motor.rated_power / wb
    rs = motor.stator_copper_loss * motor.rated_power / (1.5 * i_rated ** 2)
    s_r = motor.rated_slip
    we = p * wb / (1.0 - s_r)

    def row(x):
        lm, leak, rr = np.exp(x)
        r = np.zeros(N_MOTOR_PARAMS)
        r[MP_P], r[MP_RS], r[MP_RR] = p, rs, rr
        r[MP_LM], r[MP_LS], r[MP_LR] = lm, lm * (1.0 + leak), lm * (1.0 + leak)
        return r

    def residual(x):
        r = row(x)
        c = equivalent_circuit(r, v, we, s_r)
        tb, _ = breakdown_torque(r, v, wmax)
        return [c["torque"] / t_rated - 1.0, c["stator_current"] / i_rated - 1.0,
                math.log(motor.breakdown_margin * tb * wmax / motor.rated_power)]

    # start: magnetising reactance of about 2 per unit, leakage 5 % of it
    z_base = v / i_rated
    x0 = np.log([2.0 * z_base / we, 0.05, s_r * z_base])
    x, _, ok, msg = fsolve(residual, x0, full_output=True, xtol=tol)
    if ok != 1 or max(abs(e) for e in residual(x)) > 1e-8:
        raise ValueError(f"motor parameters: the ratings admit no equivalent circuit ({msg})")
    r = row(x)
    c = equivalent_circuit(r, v, we, s_r)
    return {
        "stator_resistance": rs,
        "rotor_resistance": r[MP_RR],
        "stator_leakage_inductance": r[MP_LS] - r[MP_LM],
        "rotor_leakage_inductance": r[MP_LR] - r[MP_LM],
        "magnetising_inductance": r[MP_LM],
        "rated_frequency": we / (2.0 * math.pi),
        "power_factor": c["power_factor"],
        "rotor_flux": c["rotor_flux"],
    }
