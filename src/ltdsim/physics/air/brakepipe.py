"""The brake pipe: one-dimensional unsteady isothermal flow of air along the train.

The brake pipe runs continuously from the lead vehicle to the last (the pipe of every
vehicle and the hoses between them, end cocks closed at both ends). Its air is modelled
as a one-dimensional compressible flow in a rigid pipe of bore ``D`` (m), area
``A = pi D^2 / 4`` (m^2), at one temperature ``T`` (K) everywhere.

Equations
---------
With the pressure ``p`` (Pa, absolute), the density ``rho = p / (R T)`` (kg/m^3) and the
mass flow ``q = rho u A`` (kg/s, + towards the rear), mass and momentum balances over
the bore read::

    A dp/dt / (R T)   = -dq/dx + s(x)                              (mass)
    dq/dt             = -A dp/dx - d(q u)/dx - f q |q| / (2 D A rho)  (momentum)

``s`` (kg/(s m)) is what enters from the side: the driver's valve, the control valves'
draw, vents and leaks. The last term is the wall friction of Darcy-Weisbach: wall shear
``f rho u |u| / 8`` over the wetted perimeter ``pi D``. ``f`` is the Darcy friction factor
of the local Reynolds number ``Re = |q| D / (A mu)`` (``mu`` the dynamic viscosity of
air, Pa s; with ``q`` fixed ``Re`` does not depend on pressure). The term ``d(q u)/dx`` is
the momentum carried by the flow (the convective term).

Isothermal air. The pipe's wall (steel, some 4 mm thick, with a large area per volume
of air) exchanges heat with the air faster than the pipe charges or applies, so the air
keeps the wall's temperature; then ``p = rho R T`` closes the system without an energy
equation and the speed of small waves is the isothermal ``c = sqrt(R T)`` (290 m/s at
20 C), which agrees with the 250-300 m/s measured for brake-pipe emergency propagation
better than the adiabatic 343 m/s. The fluid-dynamic brake-pipe models of the literature
that LTD codes use make the same choice or carry the energy equation only to find the
temperature near-constant: Afshari, Specchia, Shabana and Caldwell (A train air brake
force model: locomotive automatic brake valve and brake pipe flow formulations, Proc.
IMechE Part F, 2013) write one-dimensional isothermal continuity and momentum equations
for the pipe; Wu, Cole, Spiryagin et al. (Railway air brake model and parallel
computing scheme, J. Comput. Nonlinear Dyn. 12(5), 051017, 2017) solve the pipe's gas
dynamics by characteristics; the review of Wu et al. (Freight train air brake models,
Int. J. Rail Transp. 11(1), 1-49, 2023) classifies them.

Wall friction
-------------
Laminar flow has ``f = 64 / Re``; turbulent flow the explicit law of Haaland (Simple
and explicit formulas for the friction factor in turbulent pipe flow, J. Fluids Eng.
105, 89-90, 1983), within about 2 % of Colebrook's::

    1 / sqrt(f) = -1.8 log10((eps / D / 3.7)^1.11 + 6.9 / Re)

with the wall roughness ``eps`` (m). Between ``Re = 2300`` and ``4000`` the two are
blended with a cubic smoothstep weight, continuous in value and slope.

Near zero flow ``f`` itself is unbounded (``64 / Re``), but the friction term is not:
the code never forms ``f``. It carries ``phi(Re) = f Re``, which is 64 in the laminar
range (including ``Re = 0``) and smooth across the blend; the friction term is then
``phi(Re) mu q / (2 D^2 rho)``, linear in ``q`` near zero flow (Hagen-Poiseuille) and
continuous with a continuous slope everywhere, so a Runge-Kutta stage meets no kink or
division by zero when a flow reverses. No artificial small-flow parameter is needed: the
laminar law is the regularisation, and it is the physics of slow flow.

Scheme
------
Finite volumes on a staggered grid (Harlow and Welch, Phys. Fluids 8, 2182-2189, 1965;
Versteeg and Malalasekera, An Introduction to Computational Fluid Dynamics: the finite
volume method, ch. 6): the pipe is cut into ``nc`` cells of lengths
``dx_i`` (m) holding the pressures ``p_i``; the ``nc - 1`` faces between neighbouring
cells hold the flows ``q_j`` (face ``j`` joins cells ``j`` and ``j + 1``; the two pipe
ends are closed faces with zero flow)::

    dp_i/dt = R T / (A dx_i) (q_{i-1} - q_i + w_i - l_i)
    dq_j/dt = [A (p_j - p_{j+1}) - (F_{j+1} - F_j)] / dx'_j
              - phi(Re_j) mu q_j / (2 D^2 rho_j)

with ``w_i`` the external inflow into cell ``i`` (kg/s), ``l_i`` its leak to atmosphere
through ``orifice_flow`` (kg/s), ``dx'_j`` the distance between the cell centres (m),
``rho_j = (p_j + p_{j+1}) / (2 R T)`` the face density and ``F_i = qc_i^2 / (rho_i A)``
the momentum flux at cell centres (kg m/s^2) from the mean ``qc_i`` of its two faces.

Mass is conserved exactly. The mass of cell ``i`` is ``A dx_i p_i / (R T)``; every face
flow leaves one cell and enters its neighbour, so the sum of ``dm_i/dt`` is the sum of
inflows minus leaks, by construction and to rounding (about 1e-16 relative) at every
Runge-Kutta stage. An explicit Runge-Kutta step is a linear combination of stage rates,
so it conserves the total too (tests/physics/test_brake_pipe.py checks 1e-9 over a transient).

Waves at the right speed. Without friction and flow the scheme is the semi-discrete wave
equation ``p_tt = R T (second difference of p)``: the wave speed ``sqrt(R T)`` enters
exactly, not through any averaging. On a uniform grid a harmonic of wavenumber ``k``
oscillates at ``omega = (2 c / dx) sin(k dx / 2)``: phase speed ``c sin(t) / t`` and group
speed ``c cos(t)``, ``t = k dx / 2 = pi dx / wavelength``. The phase speed is within 1 %
with 13 cells per wavelength (0.1 % with 41); the group speed, which carries a front,
within 1 % with 22 cells per wavelength. Coarser components lag behind a steep front
as a small ringing. The staggered grid has no odd-even decoupling (a pressure pattern
alternating from cell to cell drives the face flows at full strength), so it needs no
artificial dissipation, and it dissipates nothing: the only damping is the physical
friction and leakage. At the default of 2 cells per 15 m wagon (7.5 m cells) the phase
speed is within 1 % up to about 3 Hz and the group speed up to about 1.8 Hz: a front
that drops over 0.5 s or more (an emergency front in a 32 mm pipe) is carried at ``c``
within 1 % (tested).

The convective term is kept: in an emergency the pipe near the vent runs at Mach 0.3 and
more, where the momentum flux ``rho u^2 = M^2 p`` is a tenth of the pressure and more and
decides how much air a vent can draw through the pipe (the ``2 ln(p1/p2)`` of isothermal
pipe flow with friction; tested on a short pipe at Mach 0.74, where it makes a third of
the drop). It costs one product per face and
no extra state. It is written centred (no upwinding): friction, which at these Reynolds
numbers damps a cell's momentum within a few milliseconds, dominates it everywhere the
flow is fast. At the two closed ends the momentum flux uses the mean of the end face and
the closed wall, so inflow from the side into an end cell (the driver's valve at the
head) enters without axial momentum: a local loss of order ``rho u^2`` in that cell only.

Stiffness. The fastest rates of the linearised pipe are the acoustic ``2 (c + |u|) / dx``
(77 1/s for 7.5 m cells), friction ``d(friction)/dq`` (1.75-2 times ``f |u| / D``,
10-200 1/s in an emergency; 0.1 1/s at rest) and a leak's ``R T G / (A dx)`` (``G`` the
orifice conductance). :func:`pipe_max_rate` bounds them for the step-stability check;
at ltdsim's fixed steps (1e-4 s) the pipe is far from setting the step.

All pressures are absolute, Pa; flows kg/s; lengths m; times s.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.linalg import eigvalsh_tridiagonal

from ltdsim.physics.air.pneumatics import orifice_conductance, orifice_flow

#: laminar friction: Darcy f Re of fully developed laminar pipe flow (Hagen-Poiseuille), -
PHI_LAMINAR = 64.0
#: Reynolds number below which the flow is laminar (f = 64 / Re), -
RE_LAMINAR = 2300.0
#: Reynolds number above which the turbulent law (Haaland) holds alone, -
RE_TURBULENT = 4000.0
#: Sutherland's law for air (White, Viscous Fluid Flow, 3rd ed., 2006, eq. 1-36 and
#: table 1-2): reference viscosity (Pa s) at the reference temperature (K), constant (K)
SUTHERLAND_AIR = (1.716e-5, 273.15, 110.4)


def air_viscosity(temperature: float) -> float:
    """Dynamic viscosity of air, Pa s, at ``temperature`` (K), by Sutherland's law
    ``mu0 (T / T0)^1.5 (T0 + S) / (T + S)``: 1.81e-5 Pa s at 293.15 K. It does not
    depend on pressure (kinetic theory; within 1 % up to some 20 bar)."""
    mu0, t0, s = SUTHERLAND_AIR
    return mu0 * (temperature / t0) ** 1.5 * (t0 + s) / (temperature + s)


@njit(cache=True, forceinline=True)
def _rough_term(rel_rough):
    """Haaland's roughness term ``(eps / D / 3.7)^1.11``, -, of the relative roughness."""
    return (rel_rough / 3.7) ** 1.11


@njit(cache=True, forceinline=True)
def _phi(re, rough_term):
    """:func:`friction_phi` with the roughness term of :func:`_rough_term` given."""
    if re <= RE_LAMINAR:
        return PHI_LAMINAR
    s = -1.8 * math.log10(rough_term + 6.9 / re)
    turb = re / (s * s)  # Haaland's f times Re
    if re >= RE_TURBULENT:
        return turb
    b = (re - RE_LAMINAR) / (RE_TURBULENT - RE_LAMINAR)
    w = b * b * (3.0 - 2.0 * b)
    return (1.0 - w) * PHI_LAMINAR + w * turb


@njit(cache=True, forceinline=True)
def friction_phi(re, rel_rough):
    """``phi = f Re``: the Darcy friction factor times the Reynolds number, -, at
    Reynolds number ``re`` >= 0 and relative roughness ``rel_rough`` (-).

    64 in laminar flow (``re`` <= 2300, including 0), Haaland's turbulent factor times
    ``re`` above 4000, a cubic smoothstep blend between (continuous in value and slope).
    The wall friction per unit length is ``phi mu q / (2 D^2 rho)``, N/m, finite and
    linear in the flow ``q`` near zero."""
    return _phi(re, _rough_term(rel_rough))


@njit(cache=True, forceinline=True)
def friction_factor(re, rel_rough):
    """Darcy friction factor, -, at Reynolds number ``re`` > 0 and relative roughness
    ``rel_rough`` (-): 64 / Re laminar, Haaland turbulent, blended over 2300-4000."""
    return friction_phi(re, rel_rough) / re


@njit(cache=True, _nrt=False, forceinline=True)
def pipe_rates(p, q, inflow, pipe, gas, dp, dq):
    """Rates of the brake pipe's states; returns the total leak to atmosphere, kg/s.

    ``pipe`` is the tuple ``(area, dx_cell, dx_face, diameter, roughness, viscosity,
    leak_cd_area)`` and ``gas`` ``(gamma, r_gas, temperature, atmosphere, r_lin)``, each
    item as below.

    Parameters
    ----------
    p : float64[nc]
        Cell pressures, Pa (absolute).
    q : float64[nc - 1]
        Face mass flows, kg/s, + towards the rear (face ``j`` joins cells ``j``, ``j+1``).
    inflow : float64[nc]
        External mass flow INTO each cell, kg/s (driver's valve +, control valves'
        draw -, vents -); not including the leaks, which this function adds.
    area : float
        Bore area, m^2.
    dx_cell : float64[nc]
        Cell lengths, m.
    dx_face : float64[nc - 1]
        Distances between neighbouring cell centres, m.
    diameter : float
        Bore diameter, m.
    roughness : float
        Wall roughness, m.
    viscosity : float
        Dynamic viscosity of air, Pa s (:func:`air_viscosity` of the temperature:
        1.81e-5 at 20 C); 0 switches wall friction off (an inviscid pipe, for tests).
    leak_cd_area : float64[nc]
        Discharge coefficient times area of each cell's leak to atmosphere, m^2 (0:
        tight).
    gamma, r_gas, temperature, atmosphere, r_lin : float
        Ratio of specific heats (-), gas constant (J/(kg K)), temperature (K),
        atmospheric pressure (Pa, absolute) and the orifice law's linear-region ratio
        (-), as for :func:`ltdsim.physics.air.pneumatics.orifice_flow`.
    dp : float64[nc]
        Written: dp/dt, Pa/s.
    dq : float64[nc - 1]
        Written: dq/dt, kg/s^2.

    Allocates nothing; safe to call inside a compiled right-hand side."""
    area, dx_cell, dx_face, diameter, roughness, viscosity, leak_cd_area = pipe
    gamma, r_gas, temperature, atmosphere, r_lin = gas
    nc = p.shape[0]
    rt = r_gas * temperature
    leak_total = 0.0
    # mass: face flows move air between neighbours, inflow and leaks from the side
    for i in range(nc):
        qin = q[i - 1] if i > 0 else 0.0
        qout = q[i] if i < nc - 1 else 0.0
        leak = orifice_flow(p[i], atmosphere, leak_cd_area[i], gamma, r_gas, temperature,
                            r_lin)
        leak_total += leak
        dp[i] = rt / (area * dx_cell[i]) * (qin - qout + inflow[i] - leak)
    if nc < 2:
        return leak_total
    # momentum: pressure force, convected momentum, wall friction
    rough = _rough_term(roughness / diameter)
    fric = viscosity / (2.0 * diameter * diameter)
    re_scale = diameter / (area * viscosity) if viscosity > 0.0 else 0.0
    qc = 0.5 * q[0]  # cell 0: its closed end and face 0
    f_left = qc * qc * rt / (p[0] * area)
    for j in range(nc - 1):
        qr = q[j + 1] if j + 1 < nc - 1 else 0.0
        qc = 0.5 * (q[j] + qr)
        f_right = qc * qc * rt / (p[j + 1] * area)
        rate = (area * (p[j] - p[j + 1]) - (f_right - f_left)) / dx_face[j]
        if viscosity > 0.0:
            rho = 0.5 * (p[j] + p[j + 1]) / rt
            phi = _phi(abs(q[j]) * re_scale, rough)
            rate -= phi * fric * q[j] / rho
        dq[j] = rate
        f_left = f_right
    return leak_total


# --------------------------------------------------------------------- set-up helpers
class PipeGeometry(NamedTuple):
    """The brake pipe's grid (all lengths m, indices from 0)."""

    dx_cell: np.ndarray  #: cell lengths (nc), m
    dx_face: np.ndarray  #: distances between neighbouring cell centres (nc - 1), m
    x_cell: np.ndarray  #: cell centres from the head of the pipe (nc), m
    vehicle_first: np.ndarray  #: first cell of each vehicle (n vehicles)
    vehicle_cell: np.ndarray  #: the cell a vehicle's valve connects to: its middle cell


def pipe_geometry(lengths, cells_per_vehicle: int) -> PipeGeometry:
    """The grid of a brake pipe running through vehicles of pipe lengths ``lengths`` (m,
    lead first; a vehicle's length over couplers, its pipe and hoses), each cut into
    ``cells_per_vehicle`` equal cells.

    A vehicle's valve connects to the cell holding its midpoint: cell
    ``first + cells_per_vehicle // 2`` (with an even count, the cell just behind the
    midpoint; with one cell per vehicle, that cell)."""
    lengths = np.asarray(lengths, dtype=float)
    n = int(cells_per_vehicle)
    if lengths.ndim != 1 or lengths.size == 0 or np.any(~(lengths > 0.0)):
        raise ValueError("vehicle pipe lengths must be positive numbers, m")
    if n < 1:
        raise ValueError("cells_per_vehicle must be at least 1")
    dx_cell = np.repeat(lengths / n, n)
    dx_face = 0.5 * (dx_cell[:-1] + dx_cell[1:])
    x_cell = np.cumsum(dx_cell) - 0.5 * dx_cell
    first = np.arange(lengths.size) * n
    return PipeGeometry(dx_cell, dx_face, x_cell, first, first + n // 2)


def pipe_mass(p, dx_cell, area, r_gas, temperature) -> float:
    """Air mass in the pipe, kg, at cell pressures ``p`` (Pa abs): ``sum p A dx / (R T)``."""
    return float(np.sum(np.asarray(p) * np.asarray(dx_cell)) * area / (r_gas * temperature))


def highest_wavenumber(dx_cell, dx_face) -> float:
    """The pipe's highest acoustic frequency divided by the wave speed, 1/m (rad/s per
    m/s): the square root of the largest eigenvalue of the grid's second difference
    ``(1 / dx_i) ((p_{i+1} - p_i) / dx'_i - (p_i - p_{i-1}) / dx'_{i-1})`` with closed
    ends. That operator is similar (scaled by ``sqrt(dx_i)``) to a symmetric tridiagonal
    matrix, whose largest eigenvalue scipy finds directly; on a uniform grid it is
    ``(2 / dx) cos(pi / (2 nc))``."""
    dx = np.asarray(dx_cell, dtype=float)
    inv = 1.0 / np.asarray(dx_face, dtype=float)
    if dx.size < 2:
        return 0.0
    diag = np.zeros(dx.size)
    diag[:-1] += inv
    diag[1:] += inv
    diag /= dx
    off = -inv / np.sqrt(dx[:-1] * dx[1:])
    top = eigvalsh_tridiagonal(diag, off, select="i", select_range=(dx.size - 1, dx.size - 1))
    return math.sqrt(max(float(top[0]), 0.0))


def pipe_max_rate(p, q, pipe, gas) -> float:
    """Upper bound of the largest |eigenvalue| of the pipe's rates linearised at the
    state ``p`` (Pa abs), ``q`` (kg/s), 1/s (``pipe`` and ``gas`` as for
    :func:`pipe_rates`).

    Without flow the linearised pipe is, in its energy norm, a skew-symmetric acoustic
    part (frequencies up to ``omega = c`` times :func:`highest_wavenumber`, rad/s) plus a
    diagonal damping (friction's ``d(dq/dt)/dq`` per face and each leak's
    ``R T G / (A dx)`` per cell, 1/s); every eigenvalue then lies within
    ``sqrt(omega^2 + d_max^2)`` of the origin. A flow ``u`` raises the acoustic part to
    ``(c + |u|_max)`` times the bound (the characteristic speeds ``u +- c``). For the
    step check: an explicit method is stable on the pipe when ``h`` times this rate lies
    inside its stability region along the worst ray (the imaginary axis is the safe
    choice)."""
    area, dx_cell, dx_face, diameter, roughness, viscosity, leak_cd_area = pipe
    gamma, r_gas, temperature, _, r_lin = gas
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    dx_cell = np.asarray(dx_cell, dtype=float)
    rt = r_gas * temperature
    rho_face = 0.5 * (p[:-1] + p[1:]) / rt
    u_max = float(np.max(np.abs(q) / (rho_face * area))) if q.size else 0.0
    omega = (math.sqrt(rt) + u_max) * highest_wavenumber(dx_cell, dx_face)
    damp = 0.0
    if viscosity > 0.0 and q.size:
        rel = roughness / diameter
        scale = diameter / (area * viscosity)
        for qj, rho in zip(q, rho_face):
            re = abs(qj) * scale
            h = 1e-6 * re + 1e-3  # slope of phi(Re) Re by a central difference
            lo = max(re - h, 0.0)
            slope = ((re + h) * friction_phi(re + h, rel) - lo * friction_phi(lo, rel)) / (
                re + h - lo)
            damp = max(damp, viscosity * slope / (2.0 * diameter * diameter * rho))
    for cda, dx in zip(np.asarray(leak_cd_area, dtype=float), dx_cell):
        g = orifice_conductance(cda, gamma, r_gas, temperature, r_lin)
        damp = max(damp, rt * g / (area * dx))
    return math.sqrt(omega * omega + damp * damp)
