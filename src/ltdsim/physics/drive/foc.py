"""Indirect field-oriented control of the induction motor, with an average-value inverter.

The drive is the machine (:mod:`ltdsim.physics.drive.induction`, four flux linkages) and its
controller (three states), written in the controller's synchronous frame: the frame's
speed ``w_e = p w_m + w_sl`` is the rotor's electrical speed plus the slip frequency the
controller computes, so the machine's rotor flux lies on the d axis whenever the
controller's machine parameters are the machine's (the indirect scheme: Blaschke's
field orientation with the slip computed from a rotor model rather than measured flux;
Novotny and Lipo, *Vector Control and Dynamics of AC Drives*, 1996, ch. 6; Bose,
*Modern Power Electronics and AC Drives*, 2002, ch. 8). Both machine and controller
live in that frame, so the flux angle itself is not needed (an average-value inverter
applies the frame's voltage vector as it is; phase quantities are not formed).

**Inverter.** Average-value, lossless, no switching: it applies the voltage vector the
controller asks for, limited to the space-vector modulator's linear range, a circle of
radius ``V_dc / sqrt(3)`` (V peak phase). The d axis has priority: ``v_d`` is limited to
the circle, ``v_q`` to what is left (so in field weakening the flux current follows its
reference and the torque current gives way). Its DC power equals the machine's terminal power ``3/2 (v_d i_d + v_q i_q)`` (W).

**Rotor flux model and slip.** The controller's rotor flux ``psi`` (Wb, a state) follows
the measured d current through the rotor time constant ``tau_r = L_r / R_r``::

    d psi / dt = (L_m i_sd - psi) / tau_r,      w_sl = L_m i_sq / (tau_r psi)

(``psi`` floored at ``psi_min`` = 5 % of rated in the division).

**References.** The torque demand ``T_ref`` (N m, at the shaft) is limited to the
smallest of: the current limit at rated flux ``k_t i_d0 sqrt(I_max^2 - i_d0^2)``, the
power limit ``P / |w_m|`` and ``breakdown_margin`` times the breakdown torque at the
field-weakening voltage ``V_fw = voltage_margin V_dc / sqrt(3)``,
``T_bd = k_t (V_fw / w_e)^2 / (2 sigma L_s^2)`` (stator resistance neglected), where
``k_t = 3/2 p L_m^2 / L_r``. The flux current ``i_d*`` is the rated ``i_d0 = psi_0 / L_m``
below base speed; above it (field weakening) it is the largest ``i_d`` at which the
steady-state stator voltage at the limited torque ``T*`` fits ``V_fw``::

    (R_s^2 + w_e^2 L_s^2) x^2 - (V_fw^2 - 2 R_s w_e (1 - sigma) L_s T*/k_t) x
        + (R_s^2 + w_e^2 sigma^2 L_s^2) (T*/k_t)^2 = 0,     i_d* = sqrt(x)

(the larger root; the steady-state voltage equations in the rotor-flux frame with
``i_d i_q = T / k_t``). Base speed is thus where the rated flux meets the voltage
limit, not a number typed in. The torque current is ``i_q* = T* / (3/2 p L_m / L_r
psi)``, limited to ``sqrt(I_max^2 - i_d*^2)``.

**Current controllers.** PI in the synchronous frame with decoupling feed-forward. With
``sigma L_s`` the transient inductance and ``R_sigma = R_s + (L_m / L_r)^2 R_r`` the
plant seen by each loop is ``sigma L_s di/dt + R_sigma i = v - e`` where the
feed-forward ``e`` cancels the cross-coupling and the rotor's back-emf::

    e_d = -w_e sigma L_s i_sq - L_m R_r / L_r^2 psi
    e_q =  w_e sigma L_s i_sd + p w_m L_m / L_r psi

The gains ``K_p = w_c sigma L_s``, ``K_i = w_c R_sigma`` cancel the plant's pole, so each
closed loop is the first-order lag ``w_c / (s + w_c)`` of the design bandwidth ``w_c``
(rad/s; internal-model control: Harnefors and Nee, "Model-based current control of AC
machines using the internal model control method", IEEE Trans. Ind. Appl. 34 (1998)
133-141). The integrators (V) have back-calculation anti-windup: when the inverter
shortens the demand, each integrator moves by ``w_c (v_applied - v_demanded)``
(tracking time ``1 / w_c``).

**Steady state.** At a shaft speed and torque demand the drive's equilibrium is the
field-oriented one (:func:`oriented_state`: rotor flux ``L_m i_d`` on the d axis,
``psi_sd = L_s i_d``, ``psi_sq = sigma L_s i_q``, integrators ``R_sigma i``) with the
stator currents at the controller's references; :func:`drive_steady` finds those by a
fixed-point iteration (the references depend on the state only through the flux and
the slip). A drive starts there (:mod:`ltdsim.engine.lowering`), so a train started at speed
starts with its field already weakened as the law above gives.

States of the drive, :data:`DRIVE_STATES`: the machine's four flux linkages, then the
controller's flux and its two integrators. Parameters: the machine row
(:data:`ltdsim.physics.drive.induction.MOTOR_PARAMS`) and the controller row
(:data:`CTRL_PARAMS`, from :func:`controller_row`: every gain derived from the motor).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ltdsim.physics.drive.induction import (
    MP_LM,
    MP_LR,
    MP_LS,
    MP_P,
    MP_RR,
    MP_RS,
    MOTOR_STATES,
    N_MOTOR,
    IM_PRD,
    IM_PRQ,
    IM_PSD,
    IM_PSQ,
    currents,
    machine_rates,
    motor_row,
)

CTRL_STATES = (
    "flux",          # controller's rotor flux, Wb
    "integral_d",    # d current controller's integrator, V
    "integral_q",    # q current controller's integrator, V
)
DRIVE_STATES = MOTOR_STATES + CTRL_STATES
N_DRIVE = len(DRIVE_STATES)
(FOC_FLUX, FOC_ID, FOC_IQ) = range(N_MOTOR, N_DRIVE)

CTRL_PARAMS = (
    "pole_pairs",        # -
    "stator_resistance",  # R_s, ohm
    "rotor_resistance",  # R_r, ohm
    "stator_inductance",  # L_s, H
    "rotor_inductance",  # L_r, H
    "magnetising_inductance",  # L_m, H
    "sigma",             # leakage factor 1 - L_m^2 / (L_s L_r), -
    "r_sigma",           # R_s + (L_m / L_r)^2 R_r, ohm
    "tau_r",             # L_r / R_r, s
    "kp",                # proportional gain, ohm (V/A)
    "ki",                # integral gain, ohm/s
    "bandwidth",         # w_c, rad/s (also the anti-windup tracking rate)
    "rated_flux",        # psi_0, Wb
    "min_flux",          # floor of the flux in divisions, Wb
    "max_current",       # I_max, A peak (line)
    "max_power",         # W
    "voltage_margin",    # -
    "breakdown_margin",  # -
)
N_CTRL_PARAMS = len(CTRL_PARAMS)
(C_P, C_RS, C_RR, C_LS, C_LR, C_LM, C_SIGMA, C_RSIG, C_TAUR, C_KP, C_KI, C_WC, C_PSI0,
 C_PSIMIN, C_IMAX, C_PMAX, C_VMARGIN, C_BDMARGIN) = range(N_CTRL_PARAMS)

DRIVE_OUTPUTS = (
    "torque",         # electromagnetic torque, N m
    "dc_power",       # inverter DC power (= terminal power), W
    "v_d",            # applied voltage, d, V peak
    "v_q",            # applied voltage, q, V peak
    "i_d",            # stator current, d, A peak
    "i_q",            # stator current, q, A peak
    "i_d_ref",        # flux current reference, A peak
    "i_q_ref",        # torque current reference, A peak
    "torque_ref",     # limited torque demand, N m
    "w_e",            # frame (stator) angular frequency, rad/s
    "rotor_flux",     # magnitude of the machine's rotor flux, Wb
    "flux_ref",       # rotor flux reference L_m i_d*, Wb
)
N_OUT = len(DRIVE_OUTPUTS)
(O_T, O_PDC, O_VD, O_VQ, O_ID, O_IQ, O_IDREF, O_IQREF, O_TREF, O_WE, O_PSIR,
 O_PSIREF) = range(N_OUT)


@njit(cache=True, forceinline=True)
def _flux_current(t, we, vfw, c):
    """Flux current reference, A peak: the rated one, or the field-weakening one at which
    the steady-state voltage at torque ``t`` (N m) and frequency ``we`` (rad/s) is
    ``vfw`` (V peak)."""
    id0 = c[C_PSI0] / c[C_LM]
    rs = c[C_RS]
    ls = c[C_LS]
    sig = c[C_SIGMA]
    kt = 1.5 * c[C_P] * c[C_LM] * c[C_LM] / c[C_LR]
    tk = t / kt
    a = rs * rs + we * we * ls * ls
    b = vfw * vfw - 2.0 * rs * we * (1.0 - sig) * ls * tk
    cc = (rs * rs + we * we * sig * sig * ls * ls) * tk * tk
    disc = b * b - 4.0 * a * cc
    if b <= 0.0:
        return 0.0
    if disc < 0.0:
        x = b / (2.0 * a)          # beyond breakdown: the flux of the largest torque
    else:
        x = (b + math.sqrt(disc)) / (2.0 * a)
    return min(id0, math.sqrt(x))


@njit(cache=True, forceinline=True)
def drive_rates(y, wm, t_ref, v_dc, m, c, dy, out):
    """Rates of the drive's states; returns the electromagnetic torque.

    Parameters
    ----------
    y : float64 array (N_DRIVE)
        :data:`DRIVE_STATES`: flux linkages Wb, controller flux Wb, integrators V.
    wm : float
        Shaft (rotor mechanical) speed, rad/s, from the wheelset.
    t_ref : float
        Torque demand at the shaft, N m (positive motoring in the direction of ``wm > 0``).
    v_dc : float
        DC-link voltage, V.
    m : float64 array
        The machine row (:data:`ltdsim.physics.drive.induction.MOTOR_PARAMS`).
    c : float64 array (N_CTRL_PARAMS)
        The controller row (:func:`controller_row`).
    dy : float64 array (N_DRIVE)
        Written: the rates (Wb/s, V/s).
    out : float64 array (N_OUT)
        Written: :data:`DRIVE_OUTPUTS` (SI units as listed there).

    Returns
    -------
    float
        Electromagnetic torque on the rotor, N m.
    """
    p = c[C_P]
    lm = c[C_LM]
    lr = c[C_LR]
    ls = c[C_LS]
    sls = c[C_SIGMA] * ls
    taur = c[C_TAUR]
    wr = p * wm
    isd, isq, _, _ = currents(y, m)
    psi = y[FOC_FLUX]
    psi_div = max(psi, c[C_PSIMIN])
    wsl = lm * isq / (taur * psi_div)
    we = wr + wsl

    # --- references: torque limits, flux (field weakening), currents ---
    vmax = v_dc / math.sqrt(3.0)
    vfw = c[C_VMARGIN] * vmax
    kt = 1.5 * p * lm * lm / lr
    id0 = c[C_PSI0] / lm
    imax = c[C_IMAX]
    t_lim = kt * id0 * math.sqrt(max(imax * imax - id0 * id0, 0.0))
    awm = abs(wm)
    if awm * t_lim > c[C_PMAX]:
        t_lim = c[C_PMAX] / awm
    awe = abs(we)
    if awe > 0.0:
        t_bd = c[C_BDMARGIN] * kt * (vfw / awe) ** 2 / (2.0 * sls * ls)
        t_lim = min(t_lim, t_bd)
    t_star = min(max(t_ref, -t_lim), t_lim)
    # the voltage law wants the torque's sign relative to the frame's rotation
    t_gen = t_star if we >= 0.0 else -t_star
    id_ref = _flux_current(t_gen, awe, vfw, c)
    iq_ref = t_star / (1.5 * p * lm / lr * psi_div)
    iq_max = math.sqrt(max(imax * imax - id_ref * id_ref, 0.0))
    iq_ref = min(max(iq_ref, -iq_max), iq_max)

    # --- PI current controllers with decoupling, voltage limit, anti-windup ---
    ed = id_ref - isd
    eq = iq_ref - isq
    vd_ff = -we * sls * isq - lm * c[C_RR] / (lr * lr) * psi
    vq_ff = we * sls * isd + wr * lm / lr * psi
    vd_dem = y[FOC_ID] + c[C_KP] * ed + vd_ff
    vq_dem = y[FOC_IQ] + c[C_KP] * eq + vq_ff
    # d axis first (the flux must follow its reference), the q axis gets what is left
    vd = min(max(vd_dem, -vmax), vmax)
    vq_lim = math.sqrt(max(vmax * vmax - vd * vd, 0.0))
    vq = min(max(vq_dem, -vq_lim), vq_lim)
    wc = c[C_WC]
    dy[FOC_FLUX] = (lm * isd - psi) / taur
    dy[FOC_ID] = c[C_KI] * ed + wc * (vd - vd_dem)
    dy[FOC_IQ] = c[C_KI] * eq + wc * (vq - vq_dem)

    te = machine_rates(y, vd, vq, we, wr, m, dy)
    out[O_T] = te
    out[O_PDC] = 1.5 * (vd * isd + vq * isq)
    out[O_VD] = vd
    out[O_VQ] = vq
    out[O_ID] = isd
    out[O_IQ] = isq
    out[O_IDREF] = id_ref
    out[O_IQREF] = iq_ref
    out[O_TREF] = t_star
    out[O_WE] = we
    out[O_PSIR] = math.sqrt(y[IM_PRD] * y[IM_PRD] + y[IM_PRQ] * y[IM_PRQ])
    out[O_PSIREF] = lm * id_ref
    return te


# --- set-up in Python ---------------------------------------------------------------------

def controller_row(motor) -> np.ndarray:
    """The controller's parameter row (:data:`CTRL_PARAMS`, float64) from a
    :class:`ltdsim.scenario.motor.Motor`: the controller knows the machine exactly (its
    parameters are the motor's), every gain is derived from them and the bandwidth."""
    from ltdsim.physics.drive.induction import line_current_peak

    m = motor_row(motor)
    c = np.zeros(N_CTRL_PARAMS)
    c[C_P], c[C_RS], c[C_RR] = m[MP_P], m[MP_RS], m[MP_RR]
    c[C_LS], c[C_LR], c[C_LM] = m[MP_LS], m[MP_LR], m[MP_LM]
    c[C_SIGMA] = 1.0 - m[MP_LM] ** 2 / (m[MP_LS] * m[MP_LR])
    c[C_RSIG] = m[MP_RS] + (m[MP_LM] / m[MP_LR]) ** 2 * m[MP_RR]
    c[C_TAUR] = m[MP_LR] / m[MP_RR]
    wc = 2.0 * math.pi * motor.current_bandwidth
    c[C_WC] = wc
    c[C_KP] = wc * c[C_SIGMA] * m[MP_LS]
    c[C_KI] = wc * c[C_RSIG]
    c[C_PSI0] = rated_flux(motor, m)
    c[C_PSIMIN] = 0.05 * c[C_PSI0]
    c[C_IMAX] = line_current_peak(motor.max_current, motor.connection)
    c[C_PMAX] = motor.rated_power
    c[C_VMARGIN] = motor.voltage_margin
    c[C_BDMARGIN] = motor.breakdown_margin
    return c


def time_constants(c: np.ndarray) -> tuple[float, float]:
    """The drive's two fastest first-order lags from its controller row ``c``
    (:data:`CTRL_PARAMS`), s: the current loops' ``1 / (2 pi current_bandwidth)`` and the
    stator's transient ``sigma L_s / R_sigma`` (the plant pole the loops' PI cancels,
    which stays a mode of the state)."""
    return 1.0 / c[C_WC], c[C_SIGMA] * c[C_LS] / c[C_RSIG]


def rated_flux(motor, m=None) -> float:
    """Rotor flux of the rated point (Wb peak): the equivalent circuit at base speed and
    rated slip with the phase voltage ``voltage_margin V_dc / sqrt(3)``."""
    from ltdsim.physics.drive.induction import equivalent_circuit

    if m is None:
        m = motor_row(motor)
    wb = motor.base_speed * math.pi / 30.0
    we = motor.pole_pairs * wb / (1.0 - motor.rated_slip)
    v = motor.voltage_margin * motor.dc_link_voltage / math.sqrt(3.0)
    return float(equivalent_circuit(m, v, we, motor.rated_slip)["rotor_flux"])


def oriented_state(m: np.ndarray, c: np.ndarray, i_d: float, i_q: float,
                   flux: float | None = None) -> np.ndarray:
    """States (:data:`DRIVE_STATES`) of the field-oriented steady state with the stator
    currents ``i_d``, ``i_q`` (A peak, in the rotor-flux frame), in closed form
    (``flux``, Wb: the rotor flux ``L_m i_d`` when it is known exactly, e.g. the rated
    flux; default ``L_m i_d``).

    With the rotor flux on the d axis and constant (``d psi_r / dt = 0``, ``psi_rq =
    0``) the rotor current is ``i_rd = 0``, ``i_rq = -L_m / L_r i_q``, so::

        psi_rd = L_m i_d,   psi_rq = 0,   psi_sd = L_s i_d,   psi_sq = sigma L_s i_q

    (Wb); the controller's flux is the machine's, ``L_m i_d``; each current loop's
    integrator holds the voltage its axis needs beyond the feed-forward, ``R_sigma i``
    (V; with the steady-state stator voltages ``v_d = R_s i_d - w_e sigma L_s i_q``,
    ``v_q = R_s i_q + w_e L_s i_d`` and the slip ``w_sl = i_q / (tau_r i_d)`` the
    frame speed cancels out). It is a steady state of :func:`drive_rates` when the
    currents are the controller's references there and the inverter does not limit the
    voltage (:func:`drive_steady` finds them)."""
    lm, ls, lr = m[MP_LM], m[MP_LS], m[MP_LR]
    psi = lm * i_d if flux is None else float(flux)
    y = np.zeros(N_DRIVE)
    y[IM_PSD] = ls * i_d
    y[IM_PSQ] = (ls - lm * lm / lr) * i_q      # sigma L_s i_q
    y[IM_PRD] = psi
    y[FOC_FLUX] = psi
    y[FOC_ID] = c[C_RSIG] * i_d
    y[FOC_IQ] = c[C_RSIG] * i_q
    return y


def drive_init(m: np.ndarray, c: np.ndarray, flux: float | None = None) -> np.ndarray:
    """States (:data:`DRIVE_STATES`) of a drive magnetised to ``flux`` (Wb; default the
    rated flux) at standstill with no torque: the steady state of the d-axis loop
    (rotor flux ``flux`` on the d axis, stator current ``flux / L_m``, integrator at the
    voltage ``R_sigma i_d`` it holds). A steady state at any speed only below the speed
    where field weakening begins at no torque; :func:`drive_steady` is the steady state
    at any speed and torque demand."""
    psi = c[C_PSI0] if flux is None else float(flux)
    return oriented_state(m, c, psi / m[MP_LM], 0.0, psi)


def drive_steady(m: np.ndarray, c: np.ndarray, wm: float, t_ref: float, v_dc: float,
                 *, tol: float = 1e-12, max_iter: int = 200) -> np.ndarray:
    """States (:data:`DRIVE_STATES`) of the drive in steady state at the shaft speed
    ``wm`` (rad/s) under the torque demand ``t_ref`` (N m at the shaft) with the DC link
    at ``v_dc`` (V): the equilibrium of :func:`drive_rates` the controller holds there.

    The controller's references depend on the state only through its flux ``psi`` and
    the slip (which sets ``w_e``, and with it the field-weakening flux and the
    breakdown limit); in the field-oriented steady state (:func:`oriented_state`) the
    stator currents are the references. So the currents are the fixed point of::

        (i_d, i_q) <- (i_d*, i_q*) of drive_rates at oriented_state(i_d, i_q)

    iterated from the rated flux current and no torque current until neither changes by
    more than ``tol`` x the current limit (A). Below base speed it ends at once at
    ``i_d = psi_0 / L_m``; above it ``i_d`` is the field-weakening flux current at the
    frame speed ``p wm + i_q / (tau_r i_d)`` and the limited torque ``T*``, and ``i_q =
    T* / (3/2 p L_m^2 / L_r i_d)`` (or what the current limit leaves). The study's motor
    takes at most 15 iterations over 0-80 m/s (gear 5.02, 0.625 m wheels) and demands
    of +-10 kN m.

    The field-weakening law puts the steady-state voltage at ``voltage_margin`` x the
    inverter's limit, so the inverter does not shorten it and the integrators hold
    ``R_sigma i``: the state is an equilibrium. That is checked here: every rate of
    :func:`drive_rates` must be below 1e-9 of its scale (the inverter's limit ``V_dc /
    sqrt(3)`` for the fluxes, Wb/s; ``K_i I_max`` for the integrators, V/s), else
    ``ValueError``."""
    dy = np.zeros(N_DRIVE)
    out = np.zeros(N_OUT)
    imax = c[C_IMAX]
    i_d, i_q = c[C_PSI0] / m[MP_LM], 0.0
    for _ in range(max_iter):
        drive_rates(oriented_state(m, c, i_d, i_q), wm, t_ref, v_dc, m, c, dy, out)
        d_new, q_new = out[O_IDREF], out[O_IQREF]
        done = max(abs(d_new - i_d), abs(q_new - i_q)) <= tol * imax
        i_d, i_q = d_new, q_new
        if done:
            break
    # (the rated flux current below base speed: the flux is then the rated one exactly,
    # and at standstill without torque the state is drive_init's, bit for bit)
    y = oriented_state(m, c, i_d, i_q, c[C_PSI0] if i_d == c[C_PSI0] / c[C_LM] else None)
    drive_rates(y, wm, t_ref, v_dc, m, c, dy, out)
    scale = np.full(N_DRIVE, v_dc / math.sqrt(3.0))
    scale[FOC_ID] = scale[FOC_IQ] = c[C_KI] * imax
    worst = float(np.max(np.abs(dy) / scale))
    if not worst <= 1e-9:
        raise ValueError(f"drive_steady: no steady state at shaft speed {wm:.6g} rad/s "
                         f"and torque demand {t_ref:.6g} N m (largest relative rate "
                         f"{worst:.3g} after at most {max_iter} iterations)")
    return y
