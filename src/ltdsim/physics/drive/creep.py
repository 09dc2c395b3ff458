"""Wheel-rail creep force (Polach), the driven wheelset's rotation, and its slip control.

**Creep force.** Polach's method (O. Polach, "A fast wheel-rail forces calculation
computer code", Veh. Syst. Dyn. 33 Suppl. (1999) 728-739; "Creep forces in simulations of
traction vehicles running on adhesion limit", Wear 258 (2005) 992-1000) gives the
longitudinal creep force of one wheel, N, from its creep ``s`` (-)::

    F = sign(s) 2 Q mu / pi (kA eps / (1 + (kA eps)^2) + arctan(kS eps))
    eps = (2/3) C pi a^2 b / (Q mu) |s| = pi f11 |s| / (4 Q mu)
    mu = mu0 ((1 - A) exp(-B w) + A)

``Q`` is the wheel load (N), ``a`` and ``b`` the contact ellipse's semi-axes (m, ``a``
along the rail), ``C = 3 G c11 / (8 a)`` the contact's shear stiffness per unit area
(N/m^3; ``G`` shear modulus, Pa; ``c11`` Kalker's creepage coefficient, -), so that
``f11 = G a b c11`` (N) is Kalker's linear longitudinal creep coefficient. The friction
coefficient falls with the slip velocity ``w`` (m/s) between wheel and rail from ``mu0``
at ``w = 0`` to ``A mu0`` at large ``w`` (``B``, s/m, sets how fast). The reduction
factors ``kS <= kA <= 1`` soften the curve where the contact is contaminated (wet,
low adhesion): for small creep ``F = (kA + kS) / 2 f11 s``, so with ``kA = kS = 1`` the
slope is Kalker's linear theory and the factors scale it; for large creep ``F`` tends to
``Q mu(w)``. The peak of ``F(s)`` (the adhesion optimum) exists because ``mu`` falls with
``w = |s| v``.

**Creep and its regularisation at standstill.** The creep is the slip velocity over the
rolling speed, ``s = (omega r - v) / max(|v|, v_reg)`` (wheel angular speed ``omega``
rad/s, rolling radius ``r`` m, vehicle speed ``v`` m/s). At ``|v| < v_reg`` the
denominator is held at ``v_reg`` (m/s): the force then rises with the slip velocity at
the finite slope ``(kA + kS) f11 / (2 v_reg)`` (N s/m), where the steady rolling-contact
theory's ``(kA + kS) f11 / (2 |v|)`` grows without bound as the speed falls (and its
assumption, that the contact rolls over its own length many times while the creep
changes, fails at standstill). Below ``v_reg`` the force is a function of the slip
velocity alone, the curve at ``v_reg``: its peak, the adhesion limit a start relies on,
is kept; only the slip velocity at which a force is reached changes. ``v_reg`` (a
wheelset parameter) is chosen (docs/creep.md) so that the slip velocity at the peak is
small against ``1 / B`` and the wheelset's slip mode stays within the explicit solver's
stability at the study's step. Above ``v_reg`` the law is the
unregularised one, exactly.

**Wheelset.** One driven wheelset (two wheels, each carrying half the axle load) is
turned by the wheel torque ``T_w`` (N m; the motor's shaft torque ``T_m`` times gear ratio
``i`` and gear efficiency) and held back by the creep forces::

    (J_ws + i^2 J_m) d omega / dt = T_w - 2 F r

with the wheelset's polar inertia ``J_ws`` and the motor rotor's ``J_m`` (kg m^2). The
vehicle receives ``2 F`` (N, positive forward). The motor turns at ``omega_m = i omega``.

**Slip control (re-adhesion).** A creep-velocity controller limits the wheel torque so
that the slip velocity ``w = omega r - v`` does not exceed a set value ``w_set +
w_slope |v|`` (m/s) placed near the peak of the creep curve: see :func:`slip_control`
for the law and docs/creep.md for the set value's derivation from the wet-rail curve.

All quantities SI: N, m, s, rad/s, kg m^2, Pa.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# --- parameter row of a rail condition (creep law) ----------------------------------------
CREEP_PARAMS = (
    "mu0",         # friction coefficient at zero slip velocity, -
    "A",           # ratio of the friction at infinite slip velocity to mu0, -
    "B",           # exponential decay of friction with slip velocity, s/m
    "kA",          # Polach's reduction factor in the area of adhesion, -
    "kS",          # Polach's reduction factor in the area of slip, -
)
N_CREEP_PARAMS = len(CREEP_PARAMS)
(CR_MU0, CR_A, CR_B, CR_KA, CR_KS) = range(N_CREEP_PARAMS)

# --- parameter row of a driven wheelset ---------------------------------------------------
WHEELSET_PARAMS = (
    "wheel_load",    # static vertical load of one wheel, N
    "f11",           # Kalker's longitudinal creep coefficient G a b c11 of one wheel, N
    "radius",        # rolling radius, m
    "inertia",       # J_ws + i^2 J_m: polar inertia at the wheelset, kg m^2
    "gear_ratio",    # motor speed over wheelset speed, -
    "v_reg",         # creep regularisation speed, m/s
)
N_WHEELSET_PARAMS = len(WHEELSET_PARAMS)
(WS_Q, WS_F11, WS_R, WS_J, WS_I, WS_VREG) = range(N_WHEELSET_PARAMS)

# --- slip controller ---------------------------------------------------------------------
SLIP_STATES = ("torque_limit",)  # the controller's torque limit at the wheel, N m
SLIP_PARAMS = (
    "w_set",       # slip velocity the controller holds the wheel to at most at standstill, m/s
    "w_slope",     # rise of that set value with the vehicle speed, (m/s)/(m/s)
    "gain",        # proportional gain: torque cut per m/s of slip velocity above w_set, N m s/m
    "rate",        # integral gain: rate of the limit per m/s of slip velocity error, N m/m
    "recovery",    # largest rate at which the limit rises back, N m/s
    "tracking",    # rate at which a limit above the demand follows it down, 1/s
)
N_SLIP_PARAMS = len(SLIP_PARAMS)
(SL_WSET, SL_WSLOPE, SL_GAIN, SL_RATE, SL_RECOV, SL_TRACK) = range(N_SLIP_PARAMS)


@njit(cache=True, forceinline=True)
def friction_coefficient(w, mu0, a_ratio, b_decay):
    """Polach's friction coefficient at slip velocity ``w`` (m/s, either sign),
    ``mu0 ((1 - A) exp(-B |w|) + A)``, -."""
    return mu0 * ((1.0 - a_ratio) * math.exp(-b_decay * abs(w)) + a_ratio)


@njit(cache=True, forceinline=True)
def polach_force(s, w, wheel_load, f11, mu0, a_ratio, b_decay, k_a, k_s):
    """Longitudinal creep force of one wheel, N, at creep ``s`` (-) and slip velocity
    ``w`` (m/s), Polach (2005) eqs. for pure longitudinal creep (module docstring);
    odd in ``s``. ``wheel_load`` N, ``f11`` N (Kalker's ``G a b c11``)."""
    if s == 0.0:
        return 0.0
    mu = friction_coefficient(w, mu0, a_ratio, b_decay)
    eps = math.pi * f11 * abs(s) / (4.0 * wheel_load * mu)
    ka_eps = k_a * eps
    f = 2.0 * wheel_load * mu / math.pi * (ka_eps / (1.0 + ka_eps * ka_eps)
                                           + math.atan(k_s * eps))
    return f if s > 0.0 else -f


@njit(cache=True, forceinline=True)
def creep(omega, v, radius, v_reg):
    """Regularised creep ``(omega r - v) / max(|v|, v_reg)``, -; ``omega`` rad/s, ``v``
    m/s, ``radius`` m, ``v_reg`` m/s (positive: the wheel turns faster than it rolls,
    traction)."""
    return (omega * radius - v) / max(abs(v), v_reg)


@njit(cache=True)
def creep_force(omega, v, ws, cp):
    """Creep force of the whole wheelset (two wheels) on the vehicle, N, positive
    forward, at wheelset speed ``omega`` (rad/s) and vehicle speed ``v`` (m/s);
    ``ws`` a :data:`WHEELSET_PARAMS` row, ``cp`` a :data:`CREEP_PARAMS` row."""
    w = omega * ws[WS_R] - v
    s = w / max(abs(v), ws[WS_VREG])
    return 2.0 * polach_force(s, w, ws[WS_Q], ws[WS_F11], cp[CR_MU0], cp[CR_A], cp[CR_B],
                              cp[CR_KA], cp[CR_KS])


@njit(cache=True)
def wheelset_rate(omega, v, wheel_torque, ws, cp):
    """The wheelset's angular acceleration, rad/s^2, and its creep force on the vehicle,
    N: ``(T_w - F r) / J`` with ``F`` from :func:`creep_force`; ``wheel_torque`` N m at
    the wheelset."""
    f = creep_force(omega, v, ws, cp)
    return (wheel_torque - f * ws[WS_R]) / ws[WS_J], f


@njit(cache=True)
def slip_control(torque_limit, demand, omega, v, radius, sp):
    """The slip controller: the wheel torque it lets through, N m, and the rate of its
    state ``torque_limit`` (N m/s).

    Law (a creep-velocity limiter with proportional-integral action): with the slip
    velocity ``w = omega r - v`` (m/s), the set value ``w_ref = w_set + w_slope |v|``
    (m/s; the peak of the creep curve moves to larger slip velocities as the speed
    rises) and the excess ``e = w - w_ref``,

        T_w = min(demand, torque_limit - gain max(e, 0)),  clipped to [0, demand]
        d torque_limit / dt = min(-rate e, recovery)
            and, above the demand, at most -tracking (torque_limit - demand);
            held at 0 from below and at the demand from above while it would pass them

    While ``w < w_ref`` the limit rises (at most at ``recovery`` N m/s) to the demand and
    the controller is transparent; when the wheel slips past ``w_ref`` the proportional
    term cuts the torque at once and the integral term lowers the limit until the slip
    velocity is back at ``w_ref``, where the creep force is near its peak. A limit left
    above a demand that has fallen follows it down at ``tracking`` (1/s; back-calculation
    anti-windup), so a slip after a demand cut meets a limit near the demand, not a
    wound-up one. Motoring only: a braking demand (``<= 0``) passes unchanged and the
    limit holds its value (wheel-slide protection is not modelled). The state starts at
    the largest wheel torque. ``sp`` a :data:`SLIP_PARAMS` row.
    """
    if demand <= 0.0:
        return demand, 0.0
    e = omega * radius - v - (sp[SL_WSET] + sp[SL_WSLOPE] * abs(v))
    rate = min(-sp[SL_RATE] * e, sp[SL_RECOV])
    if torque_limit > demand:
        rate = min(rate, -sp[SL_TRACK] * (torque_limit - demand))
    elif torque_limit == demand and rate > 0.0:
        rate = 0.0
    if torque_limit <= 0.0 and rate < 0.0:
        rate = 0.0
    torque = torque_limit - sp[SL_GAIN] * max(e, 0.0)
    torque = min(max(torque, 0.0), demand)
    return torque, rate


def creep_row(table: dict) -> np.ndarray:
    """A :data:`CREEP_PARAMS` row from a preset or inline table (keys as named there)."""
    return np.array([float(table[k]) for k in CREEP_PARAMS])


# --- contact geometry (Hertz) and Kalker's coefficient -------------------------------------
# Kalker's creepage coefficient c11 for Poisson's ratio 0.25 against the ellipse's axis
# ratio (J. J. Kalker, "On the rolling contact of two elastic bodies in the presence of dry
# friction", thesis, Delft 1967, table of the creepage and spin coefficients; reproduced in
# S. Iwnicki (ed.), Handbook of Railway Vehicle Dynamics, CRC 2006, ch. 4, and in K. Knothe,
# S. Stichel, Rail Vehicle Dynamics, Springer 2017). Rows are ``a / b`` (a along the rail),
# from 0.1 up to 1 and then ``b / a`` from 1 down to 0.1, written here as a / b. All 19
# values equal Kalker's Table E.3 (1990) as the CONTACT code of Vollebregt and Kalker
# carries it (tests/physics/test_creep.py). The material's Poisson's ratio is 0.28, not 0.25:
# c11 would be about 2 % larger (docs/creep.md gives the effect on the peaks).
_KALKER_AB = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0,
                       1 / 0.9, 1 / 0.8, 1 / 0.7, 1 / 0.6, 1 / 0.5, 1 / 0.4, 1 / 0.3,
                       1 / 0.2, 1 / 0.1])
_KALKER_C11 = np.array([3.31, 3.37, 3.44, 3.53, 3.62, 3.72, 3.81, 3.91, 4.01, 4.12,
                        4.22, 4.36, 4.54, 4.78, 5.10, 5.57, 6.34, 7.78, 11.7])
KALKER_POISSON = 0.25


def kalker_c11(a_over_b: float) -> float:
    """Kalker's c11 (-, Poisson's ratio 0.25) at the contact ellipse's axis ratio ``a/b``
    (0.1-10), interpolated linearly in ``log(a/b)``."""
    if not 0.1 <= a_over_b <= 10.0:
        raise ValueError(f"contact ellipse axis ratio a/b = {a_over_b:.3g} outside Kalker's "
                         "table (0.1-10)")
    return float(np.interp(math.log(a_over_b), np.log(_KALKER_AB), _KALKER_C11))


def hertz_contact(wheel_load: float, wheel_radius: float, rail_radius: float,
                  young: float, poisson: float) -> tuple[float, float]:
    """Semi-axes ``(a, b)`` of the Hertz contact ellipse, m, ``a`` along the rail, of a
    wheel (rolling radius ``wheel_radius`` m, a conical tread: no transverse curvature) on a
    rail head of transverse radius ``rail_radius`` m under ``wheel_load`` N; both bodies of
    Young's modulus ``young`` Pa and Poisson's ratio ``poisson``.

    Hertz (e.g. K. L. Johnson, *Contact Mechanics*, CUP 1985, ch. 4): the relative
    curvatures are ``A = 1/(2 R_w)`` along and ``B = 1/(2 R_r)`` across the rail; the
    ellipse's eccentricity ``e`` solves ``B/A = ((1-e^2)^-1 E(e) - K(e)) / (K(e) - E(e))``
    when ``A < B`` (long axis along the rail; the roles swap otherwise), and the long
    semi-axis is ``(3 Q E(e) / (2 pi (1-e^2) A E*))^(1/3)`` with
    ``E* = young / (2 (1 - poisson^2))`` (two equal bodies) and ``(A + B)`` written with
    the complete elliptic integrals ``K`` and ``E`` of modulus ``e``.
    """
    from scipy.optimize import brentq
    from scipy.special import ellipe, ellipk

    a_curv = 1.0 / (2.0 * wheel_radius)
    b_curv = 1.0 / (2.0 * rail_radius)
    e_star = young / (2.0 * (1.0 - poisson ** 2))
    small, large = min(a_curv, b_curv), max(a_curv, b_curv)
    if math.isclose(small, large, rel_tol=1e-4):
        # (nearly) circular contact: a sphere of radius R on a plane, R = 1 / (2 A); the
        # elliptic equations lose precision to cancellation as e -> 0, and within 1e-4 of
        # equal curvatures the circle is within 5e-5 of the ellipse's semi-axes
        radius = (3.0 * wheel_load * (1.0 / (2.0 * small)) / (4.0 * e_star)) ** (1.0 / 3.0)
        return radius, radius

    # m = e^2 (scipy's parameter); the ratio large/small of the curvatures, with the long
    # axis across the larger radius of curvature (the smaller curvature)
    def ratio(m):
        k, e = ellipk(m), ellipe(m)
        return (e / (1.0 - m) - k) / (k - e) - large / small

    m = brentq(ratio, 1e-12, 1.0 - 1e-15)
    k, e = ellipk(m), ellipe(m)
    # Johnson (4.39): (A + B) = ... ; the long semi-axis from the load:
    # Q = (2 pi / 3) p0 a_long a_short and the curvature sum B' (long axis) relation
    # small = p0 b_short / (E* a_long^2 e^2) (K - E)  =>  a_long^3 = 3 Q (K - E) / (2 pi E* e^2 small)
    # with b_short = a_long sqrt(1 - e^2)
    a_long = (3.0 * wheel_load * (k - e) / (2.0 * math.pi * e_star * m * small)) ** (1.0 / 3.0)
    a_short = a_long * math.sqrt(1.0 - m)
    if a_curv < b_curv:   # long axis along the rail
        return a_long, a_short
    return a_short, a_long


def wheelset_row(*, static_mass: float, axles: int, gravity: float, wheel_radius: float,
                 rail_radius: float, young: float, poisson: float, shear_modulus: float,
                 inertia: float, motor_inertia: float, gear_ratio: float,
                 v_reg: float) -> np.ndarray:
    """A :data:`WHEELSET_PARAMS` row for one driven wheelset of a locomotive: the wheel
    load from its static mass (kg) spread evenly on ``axles`` axles of two wheels, the
    Hertz contact and Kalker's ``f11 = G a b c11`` at that load, the inertia ``J_ws + i^2
    J_m`` (kg m^2)."""
    q = static_mass * gravity / (2.0 * axles)
    a, b = hertz_contact(q, wheel_radius, rail_radius, young, poisson)
    f11 = shear_modulus * a * b * kalker_c11(a / b)
    return np.array([q, f11, wheel_radius, inertia + gear_ratio ** 2 * motor_inertia,
                     gear_ratio, v_reg])
