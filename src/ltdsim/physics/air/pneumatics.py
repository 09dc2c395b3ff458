"""Compressible flow of air through an orifice: the law every valve of the air brake uses.

An orifice (a choke, a valve seat, a vent) of area ``A`` (m^2) and discharge
coefficient ``Cd`` (-) between an upstream pressure ``p_u`` and a downstream pressure
``p_d`` (Pa, absolute) passes the mass flow, kg/s, of an isentropic nozzle (Saint-Venant
and Wantzel; e.g. Anderson, *Modern Compressible Flow*, 3rd ed., 2003, ch. 5, and ISO
6358-1 for pneumatic components)::

    m = Cd A p_u sqrt(2 gamma / ((gamma - 1) R T)) sqrt(r^(2/gamma) - r^((gamma+1)/gamma))

with the pressure ratio ``r = p_d / p_u``, the ratio of specific heats ``gamma``, the
gas constant ``R`` (J/(kg K)) and the upstream stagnation temperature ``T`` (K). Below
the critical ratio ``r* = (2 / (gamma + 1))^(gamma / (gamma - 1))`` (0.528 for air) the
flow is choked: the throat is sonic and the flow no longer depends on ``p_d``::

    m = Cd A p_u sqrt(gamma / (R T)) (2 / (gamma + 1))^((gamma + 1) / (2 (gamma - 1)))

Near equal pressures the nozzle law behaves as ``sqrt(2 (1 - r))``: its slope in
``p_d`` is infinite at ``r = 1``, which no explicit integrator can step (a small
reservoir equalising through an orifice would set an ever smaller step). Real orifices
are viscous there (the flow turns laminar as the pressure difference vanishes), so
ltdsim makes the flow linear in the pressure difference for ratios above ``r_lin``
(``1 - r_lin`` of a few thousandths): a straight line from zero at ``r = 1`` to the
nozzle law at ``r_lin``, continuous in value. The regularisation ratio is a parameter
(data), as are the gas properties.

All functions are signed: the flow is positive from the first pressure to the second
and negative the other way; the upstream side is whichever pressure is higher, and its
temperature is the one the law takes: :func:`orifice_flow` has one temperature for both
sides (two of the valves' volumes, both at the valves' temperature), and
:func:`orifice_flow_between` one for each (the brake pipe's air, whose temperature moves
with its pressure, against a valve's volume or the atmosphere).
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, forceinline=True)
def critical_ratio(gamma):
    """Critical (choking) pressure ratio ``(2 / (gamma + 1))^(gamma / (gamma - 1))``, -."""
    return (2.0 / (gamma + 1.0)) ** (gamma / (gamma - 1.0))


@njit(cache=True, forceinline=True)
def _nozzle(r, gamma):
    """The nozzle's flow function of the pressure ratio ``r`` in (0, 1], per unit
    ``Cd A p_u / sqrt(R T)``, -: choked below the critical ratio."""
    rc = critical_ratio(gamma)
    if r <= rc:
        return math.sqrt(gamma) * (2.0 / (gamma + 1.0)) ** (
            (gamma + 1.0) / (2.0 * (gamma - 1.0)))
    return math.sqrt(2.0 * gamma / (gamma - 1.0)
                     * (r ** (2.0 / gamma) - r ** ((gamma + 1.0) / gamma)))


@njit(cache=True, forceinline=True)
def orifice_flow(p1, p2, cd_area, gamma, r_gas, temperature, r_lin):
    """Mass flow through an orifice from pressure ``p1`` to ``p2``, kg/s (negative when
    ``p2 > p1``).

    Parameters
    ----------
    p1, p2 : float
        Absolute pressures on the two sides, Pa (> 0).
    cd_area : float
        Discharge coefficient times orifice area, m^2 (0 closes the orifice).
    gamma : float
        Ratio of specific heats of air, - (1.4).
    r_gas : float
        Specific gas constant of air, J/(kg K) (287.05).
    temperature : float
        Temperature of the air, K.
    r_lin : float
        Pressure ratio above which the flow is linear in the pressure difference, -
        (in (critical ratio, 1), e.g. 0.995).
    """
    if cd_area <= 0.0 or p1 == p2:
        return 0.0
    if p1 > p2:
        pu, r, sign = p1, p2 / p1, 1.0
    else:
        pu, r, sign = p2, p1 / p2, -1.0
    scale = cd_area * pu / math.sqrt(r_gas * temperature)
    if r > r_lin:
        return sign * scale * _nozzle(r_lin, gamma) * (1.0 - r) / (1.0 - r_lin)
    return sign * scale * _nozzle(r, gamma)


@njit(cache=True, forceinline=True)
def orifice_conductance(cd_area, gamma, r_gas, temperature, r_lin):
    """Slope of :func:`orifice_flow` in the pressure difference near equal pressures,
    kg/(s Pa): the same at every pressure level (the linear region's flow
    ``Cd A psi(r_lin) (p1 - p2) / ((1 - r_lin) sqrt(R T))`` does not depend on it). It
    is the stiffest the orifice gets, for step-size limits: a volume ``V`` (m^3)
    equalising through it does so with the time constant ``V / (R T G)``, s."""
    if cd_area <= 0.0:
        return 0.0
    return (cd_area / math.sqrt(r_gas * temperature) * _nozzle(r_lin, gamma)
            / (1.0 - r_lin))


@njit(cache=True, forceinline=True)
def orifice_flow_between(p1, p2, cd_area, gamma, r_gas, t1, t2, r_lin):
    """:func:`orifice_flow` from ``p1`` at temperature ``t1`` to ``p2`` at ``t2`` (Pa abs,
    K): the law takes the upstream side's temperature, ``t1`` when ``p1 > p2`` and ``t2``
    otherwise, kg/s. Continuous across equal pressures (the flow is 0 there from either
    side), so a flow that reverses meets no jump."""
    if p1 >= p2:
        return orifice_flow(p1, p2, cd_area, gamma, r_gas, t1, r_lin)
    return orifice_flow(p1, p2, cd_area, gamma, r_gas, t2, r_lin)
