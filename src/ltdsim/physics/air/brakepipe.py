"""The brake pipe: one-dimensional unsteady flow of air along the train, with its energy.

The brake pipe runs continuously from the lead vehicle to the last (the pipe of every
vehicle and the hoses between them, end cocks closed at both ends). Its air is modelled
as a one-dimensional compressible flow in a rigid pipe of bore ``D`` (m), area
``A = pi D^2 / 4`` (m^2), whose wall stays at the ambient temperature ``T_w`` (K), with
the volumes that hang off it on every vehicle (branch pipe, dirt collector, the control
valve's pipe-side passages, the hoses' volume beyond the bore) as capacitance.

Equations
---------
With the pressure ``p`` (Pa, absolute), the density ``rho`` (kg/m^3), the temperature
``T = p / (rho R)`` (K), the mass flow ``q = rho u A`` (kg/s, + towards the rear) and the
volume per unit length ``a = A + b`` (m^2; ``b`` the side volumes per metre, m^3/m), mass,
momentum and internal energy balance over the bore read::

    a d(rho)/dt            = -dq/dx + s                                  (mass)
    dq/dt                  = -A dp/dx - d(q u)/dx - f q |q| / (2 D A rho)  (momentum)
    a/(gamma-1) dp/dt      = -d(cp T q)/dx + u A dp/dx + phi_f + h_s + Q  (energy)

``s`` (kg/(s m)) is what enters from the side: the driver's valve, the control valves'
draw, vents and leaks; ``h_s`` (W/m) the enthalpy it carries, ``cp T_w`` per kg coming
from a valve (the valves' air is at the wall's temperature, see below) and ``cp T`` per
kg leaving. The side volumes are capacitance only: their air shares the pipe's pressure
and temperature but has no axial momentum. The last momentum term is the wall friction
of Darcy-Weisbach: wall shear ``f rho u |u| / 8`` over the wetted perimeter ``pi D``;
``f`` is the Darcy friction factor of the local Reynolds number ``Re = |q| D / (A mu)``
(``mu`` the dynamic viscosity of air, Pa s; with ``q`` fixed ``Re`` does not depend on
pressure). The term ``d(q u)/dx`` is the momentum carried by the flow (the convective
term). In the energy balance ``u A dp/dx + phi_f`` (W/m) is the internal energy's share
of the mechanical work (the pressure's work on the moving air and the friction's
dissipation, which heats it: what turns a total-energy balance into this internal-energy
one), and ``Q = h pi D (T_w - T)`` (W/m) the heat the wall gives the air, with the heat
transfer coefficient ``h = Nu k / D`` (``k`` the air's thermal conductivity, W/(m K),
``Nu`` the Nusselt number of the local flow).

Why an energy balance. A pressure wave in a 32 mm pipe is faster than the wall's
exchange with the air: at rest the air exchanges heat with the wall in ``tau = rho cv D^2
/ (4 Nu k)``, some 14 s at 6 bar (``Nu`` = 3.66, laminar), while a front rises in a
fraction of a second, so a front runs at the adiabatic speed of sound
``sqrt(gamma R T)`` (343 m/s at 20 C), not at the isothermal ``sqrt(R T)`` (290 m/s);
slow charging and leaks, over tens of seconds to minutes, stay near the wall's
temperature. Turbulent flow exchanges much faster (``Nu`` of hundreds behind an
emergency vent, ``tau`` of tenths of a second down to milliseconds), so the air an
emergency vent expands and cools is warmed again within a second. The earlier model of
this module held the air isothermal (``sqrt(R T)`` for every wave); it is kept as the
``isothermal`` mode. What slows an emergency front below 343 m/s in a train is the side
volumes (capacitance without inertance: small waves run at ``c sqrt(A / (A + b))``),
wall friction, and the valves' draws and delays; with the presets' volumes the front
runs at 276-283 m/s end to end at 20 C on the shipped trains (docs/airbrake.md), inside
the 270-290 m/s of North American emergency applications and above UIC 540's 250 m/s,
and with ``sqrt(T)`` (258-264 m/s at -20 C); that the air's temperature changes the
sonic pressure wave's transmission was found on a train-equivalent brake rig (Fluids
6(10), 351, 2021, doi 10.3390/fluids6100351, University of Oviedo; its abstract).

Literature. Fluid-dynamic brake-pipe models write mass, momentum and energy balances
(Advances in Mechanical Engineering, 2023, doi 10.1177/16878132231169618, whose
introduction classifies them so); Wu, Cole, Spiryagin et al. (Railway air brake model and
parallel computing scheme, J. Comput. Nonlinear Dyn. 12(5), 051017, 2017) solve the
pipe's gas dynamics by characteristics with a boundary condition of their own at the hose
connections; Afshari, Specchia, Shabana and Caldwell (A train air brake force model:
locomotive automatic brake valve and brake pipe flow formulations, Proc. IMechE Part F,
2013) simplify to one-dimensional isothermal continuity and momentum equations with
branch-pipe flows; Ge, Chen, Ling, Zhai and Wang (An approach for simulating the air
brake system of long freight trains based on fluid dynamics, Railway Engineering Science,
2023) give branch pipes boundary conditions of their own; the review of Wu et al.
(Freight train air brake models, Int. J. Rail Transp. 11(1), 1-49, 2023) classifies the
models; Ripley (An investigation of brake application delays in Australian train brake
systems, M.Eng. thesis, Central Queensland University, 2004) measured application delays
on a 120 m rig with different branch-pipe lengths.

Modes (``thermal``): :data:`THERMAL_WALL` the balance above; :data:`THERMAL_ADIABATIC`
the same without the wall's heat (``Q = 0``, for tests against isentropic closed forms);
:data:`THERMAL_ISOTHERMAL` the air always at ``T_w`` (``p = rho R T_w``, the energy
balance replaced by an infinitely fast wall: waves at ``sqrt(R T)``).

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

Wall heat
---------
The Nusselt number is that of fully developed pipe flow at a wall of fixed temperature:
3.66 in laminar flow and at rest (e.g. Incropera and DeWitt, Fundamentals of Heat and
Mass Transfer, ch. 8), Gnielinski's correlation in turbulent flow (V. Gnielinski, New
equations for heat and mass transfer in turbulent pipe and channel flow, Int. Chem. Eng.
16, 359-368, 1976; within some 10 % of measurements for ``Re`` 3000-5e6)::

    Nu = (f/8) (Re - 1000) Pr / (1 + 12.7 sqrt(f/8) (Pr^(2/3) - 1))

with Haaland's ``f`` of the same face (one logarithm serves both) and the Prandtl number
``Pr = mu cp / k``; blended over ``Re`` 2300-4000 with the friction's weight. A cell
takes the mean of its two faces' ``Nu`` (a closed end counts as a face at rest). The
exchange is quasi-steady: the thermal boundary layer of an oscillation (Kirchhoff's
correction to the speed of sound in a tube, which grows as ``omega^-1/2``) is left out,
and so is the wall's own heat capacity (its temperature stays ``T_w``). The side volumes
exchange through the pipe's wall area only.

Scheme
------
Finite volumes on a staggered grid (Harlow and Welch, Phys. Fluids 8, 2182-2189, 1965;
Versteeg and Malalasekera, An Introduction to Computational Fluid Dynamics: the finite
volume method, ch. 6): the pipe is cut into ``nc`` cells of lengths ``dx_i`` (m) and
volumes ``V_i = A dx_i + B_i`` (m^3, ``B_i`` the side volumes the cell carries) holding
the pressures ``p_i`` and densities ``rho_i``; the ``nc - 1`` faces between neighbouring
cells hold the flows ``q_j`` (face ``j`` joins cells ``j`` and ``j + 1``; the two pipe
ends are closed faces with zero flow)::

    d(rho_i)/dt = (q_{i-1} - q_i + w_i - l_i) / V_i
    dp_i/dt     = (gamma - 1) / V_i (H_{i-1} - H_i + h_i + (S_{i-1} + S_i) / 2 + Q_i)
    dq_j/dt     = [A (p_j - p_{j+1}) - (F_{j+1} - F_j)] / dx'_j - fr_j,
    fr_j        = phi(Re_j) mu q_j / (2 D^2 rho_j)

with ``w_i`` the net external inflow into cell ``i`` (kg/s), ``l_i`` its leak to
atmosphere through ``orifice_flow`` at the cell's temperature (kg/s), ``dx'_j`` the
distance between the cell centres (m), ``rho_j = (rho_j + rho_{j+1}) / 2`` the face
density, ``F_i = qc_i^2 / (rho_i A)`` the momentum flux at cell centres (kg m/s^2) from
the mean ``qc_i`` of its two faces; ``H_j = cp T_up q_j`` the enthalpy flux of face
``j`` (W) at the temperature of the cell upwind of it; ``h_i = cp (T_w f_i - T_i (f_i -
w_i + l_i))`` the side's enthalpy (W: the valves' feed ``f_i`` >= 0 at the wall's
temperature, the rest of the exchange at the cell's); ``S_j = u_j (A (p_{j+1} - p_j) +
fr_j dx'_j)`` the face's mechanical work share (W, half to each neighbour; ``u_j = q_j /
(rho_j A)``) and ``Q_i = Nu_i k pi dx_i (T_w - T_i)`` the wall's heat (W). In the
isothermal mode ``dp_i/dt = R T_w d(rho_i)/dt`` instead.

Mass is conserved exactly. The mass of cell ``i`` is ``rho_i V_i``, linear in the state;
every face flow leaves one cell and enters its neighbour, so the sum of ``dm_i/dt`` is
the sum of inflows minus leaks, by construction and to rounding (about 1e-16 relative) at
every Runge-Kutta stage. An explicit Runge-Kutta step is a linear combination of stage
rates, so it conserves the total too (tests/physics/test_brake_pipe.py checks 1e-9 over a
transient). The pressure is a state of its own (the internal energy ``p V / (gamma -
1)``), not ``rho R T`` of a temperature state, so that this stays linear.

Energy. The cells' internal energies change by the enthalpy the flows carry, the
mechanical work's share and the wall's heat; the kinetic energy lives at the faces.
Their sum is conserved to the scheme's order, not to rounding: steady adiabatic flow
keeps its stagnation temperature within 0.2 % along a pipe at Mach 0.3-0.5 (the Fanno
test), and the head cell, which takes the driver's valve's air from the side, gives the
flow its kinetic energy partly from the pressure's work at its face rather than all from
its enthalpy (1 % of the temperature at Mach 0.34); a cell the flow leaves sideways (a
vent) stops it and takes its kinetic energy as heat. None of this enters the train's
mechanical energy accounting, which counts the brake shoes' work.

Waves at the right speed. Without friction, heat and flow the scheme is the
semi-discrete wave equation ``p_tt = gamma R T (A / a)`` (second difference of p): the
wave speed ``c = sqrt(gamma R T A / a)`` enters exactly, not through any averaging
(``sqrt(R T A / a)`` isothermal). On a uniform grid a harmonic of wavenumber ``k``
oscillates at ``omega = (2 c / dx) sin(k dx / 2)``: phase speed ``c sin(t) / t`` and
group speed ``c cos(t)``, ``t = k dx / 2 = pi dx / wavelength``. The phase speed is
within 1 % with 13 cells per wavelength (0.1 % with 41); the group speed, which carries a
front, within 1 % with 22 cells per wavelength. Coarser components lag behind a steep
front as a small ringing. The staggered grid has no odd-even decoupling (a pressure
pattern alternating from cell to cell drives the face flows at full strength), so it
needs no artificial dissipation, and its acoustics dissipate nothing: the damping is the
physical friction, the wall's heat exchange and leakage (the upwind enthalpy flux
smears only the temperature the flow carries, at the flow's speed). At the default of 2
cells per 15 m wagon (7.5 m cells) the phase speed is within 1 % up to about 3.5 Hz and
the group speed up to about 2 Hz: a front that drops over 0.5 s or more (an emergency
front in a 32 mm pipe) is carried at ``c`` within 1 % (tested).

The convective term is kept: in an emergency the pipe near the vent runs at Mach 0.3 and
more, where the momentum flux ``rho u^2 = M^2 gamma p`` is a tenth of the pressure and
more and decides how much air a vent can draw through the pipe (tested on a short pipe
at Mach 0.74 against the closed forms of isothermal and of adiabatic (Fanno) flow with
friction). It costs one product per face and no extra state. It is written centred (no
upwinding): friction, which at these Reynolds numbers damps a cell's momentum within a
few milliseconds, dominates it everywhere the flow is fast. At the two closed ends the
momentum flux uses the mean of the end face and the closed wall, so inflow from the side
into an end cell (the driver's valve at the head) enters without axial momentum: a local
loss of order ``rho u^2`` in that cell only.

Stiffness. The fastest rates of the linearised pipe are the acoustic ``2 (c + |u|) / dx``
(92 1/s for 7.5 m cells at 343 m/s), friction ``d(friction)/dq`` (1.75-2 times ``f |u| /
D``, 10-200 1/s in an emergency; 0.1 1/s at rest), the wall's heat ``(gamma - 1) Nu k pi
dx / (V R rho)`` (0.03 1/s at rest, some 100 1/s in a vent's turbulent flow) and a leak's
``gamma R T G / V`` (``G`` the orifice conductance). :func:`pipe_max_rate` bounds them for
the step-stability check; at ltdsim's fixed steps (1e-4 s) the pipe is far from setting
the step.

All pressures are absolute, Pa; densities kg/m^3; flows kg/s; temperatures K; lengths
m; volumes m^3; times s.
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
#: Nusselt number of fully developed laminar pipe flow at a wall of fixed temperature
#: (Incropera and DeWitt, Fundamentals of Heat and Mass Transfer, ch. 8), -
NU_LAMINAR = 3.66
#: Sutherland's law for air (White, Viscous Fluid Flow, 3rd ed., 2006, eq. 1-36 and
#: table 1-2): reference viscosity (Pa s) at the reference temperature (K), constant (K)
SUTHERLAND_AIR = (1.716e-5, 273.15, 110.4)
#: Sutherland's law for the thermal conductivity of air (White, Viscous Fluid Flow, 3rd
#: ed., 2006, eq. 1-42 and table 1-3): reference conductivity (W/(m K)) at the reference
#: temperature (K), constant (K)
SUTHERLAND_AIR_CONDUCTIVITY = (0.0241, 273.0, 194.0)
#: the pipe air's thermal modes (the ``thermal`` item of :func:`pipe_rates`' gas):
#: energy balance with the wall's heat, without it, the air held at the wall's temperature
THERMAL_MODES = ("wall", "adiabatic", "isothermal")
THERMAL_WALL, THERMAL_ADIABATIC, THERMAL_ISOTHERMAL = range(len(THERMAL_MODES))


def air_viscosity(temperature: float) -> float:
    """Dynamic viscosity of air, Pa s, at ``temperature`` (K), by Sutherland's law
    ``mu0 (T / T0)^1.5 (T0 + S) / (T + S)``: 1.81e-5 Pa s at 293.15 K. It does not
    depend on pressure (kinetic theory; within 1 % up to some 20 bar)."""
    mu0, t0, s = SUTHERLAND_AIR
    return mu0 * (temperature / t0) ** 1.5 * (t0 + s) / (temperature + s)


def air_conductivity(temperature: float) -> float:
    """Thermal conductivity of air, W/(m K), at ``temperature`` (K), by Sutherland's law
    ``k0 (T / T0)^1.5 (T0 + S) / (T + S)``: 0.0257 W/(m K) at 293.15 K, 0.0225 at 253 K.
    Like the viscosity it hardly depends on pressure."""
    k0, t0, s = SUTHERLAND_AIR_CONDUCTIVITY
    return k0 * (temperature / t0) ** 1.5 * (t0 + s) / (temperature + s)


@njit(cache=True, forceinline=True)
def _rough_term(rel_rough):
    """Haaland's roughness term ``(eps / D / 3.7)^1.11``, -, of the relative roughness."""
    return (rel_rough / 3.7) ** 1.11


@njit(cache=True, forceinline=True)
def _blend(re):
    """Weight of the turbulent law between ``RE_LAMINAR`` and ``RE_TURBULENT``, -: a cubic
    smoothstep, 0 and 1 at the ends with zero slope there."""
    b = (re - RE_LAMINAR) / (RE_TURBULENT - RE_LAMINAR)
    return b * b * (3.0 - 2.0 * b)


@njit(cache=True, forceinline=True)
def _phi(re, rough_term):
    """:func:`friction_phi` with the roughness term of :func:`_rough_term` given."""
    if re <= RE_LAMINAR:
        return PHI_LAMINAR
    s = -1.8 * math.log10(rough_term + 6.9 / re)
    turb = re / (s * s)  # Haaland's f times Re
    if re >= RE_TURBULENT:
        return turb
    w = _blend(re)
    return (1.0 - w) * PHI_LAMINAR + w * turb


@njit(cache=True, forceinline=True)
def _phi_nu(re, rough_term, prandtl, pr23):
    """``(phi, Nu)`` at Reynolds number ``re``: :func:`friction_phi` and
    :func:`nusselt` from one logarithm (``pr23`` is ``prandtl^(2/3)``), -."""
    if re <= RE_LAMINAR:
        return PHI_LAMINAR, NU_LAMINAR
    s = -1.8 * math.log10(rough_term + 6.9 / re)
    f8 = 0.125 / (s * s)  # Haaland's f / 8
    phi = 8.0 * f8 * re
    nu = f8 * (re - 1000.0) * prandtl / (1.0 + 12.7 * math.sqrt(f8) * (pr23 - 1.0))
    if re >= RE_TURBULENT:
        return phi, nu
    w = _blend(re)
    return ((1.0 - w) * PHI_LAMINAR + w * phi, (1.0 - w) * NU_LAMINAR + w * nu)


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


@njit(cache=True, forceinline=True)
def nusselt(re, rel_rough, prandtl):
    """Nusselt number ``h D / k`` of fully developed pipe flow at a wall of fixed
    temperature, -, at Reynolds number ``re`` >= 0, relative roughness ``rel_rough`` (-)
    and Prandtl number ``prandtl`` (-): :data:`NU_LAMINAR` (3.66) laminar and at rest,
    Gnielinski's correlation with Haaland's friction factor above 4000, blended between
    as the friction is (continuous in value and slope)."""
    return _phi_nu(re, _rough_term(rel_rough), prandtl, prandtl ** (2.0 / 3.0))[1]


@njit(cache=True, _nrt=False, forceinline=True)
def pipe_rates(p, q, rho, inflow, feed, pipe, gas, dp, dq, drho):
    """Rates of the brake pipe's states; returns the total leak to atmosphere, kg/s.

    ``pipe`` is the tuple ``(area, dx_cell, dx_face, volume, diameter, roughness,
    viscosity, conductivity, leak_cd_area)`` and ``gas`` ``(gamma, r_gas, temperature,
    atmosphere, r_lin, thermal)``, each item as below.

    Parameters
    ----------
    p : float64[nc]
        Cell pressures, Pa (absolute).
    q : float64[nc - 1]
        Face mass flows, kg/s, + towards the rear (face ``j`` joins cells ``j``, ``j+1``).
    rho : float64[nc]
        Cell densities, kg/m^3 (a cell's air mass is ``rho V``; its temperature
        ``p / (rho R)``, K).
    inflow : float64[nc]
        Net external mass flow INTO each cell, kg/s (driver's valve +, control valves'
        draw -, vents -); not including the leaks, which this function adds.
    feed : float64[nc]
        The part of the exchange that enters the cell from a valve, kg/s (>= 0): it
        brings the valves' air at ``temperature``; what leaves (``feed - inflow`` and the
        leak) takes the cell's.
    area : float
        Bore area, m^2.
    dx_cell : float64[nc]
        Cell lengths, m.
    dx_face : float64[nc - 1]
        Distances between neighbouring cell centres, m.
    volume : float64[nc]
        Cell volumes, m^3: the bore's ``area dx_cell`` and the side volumes the cell
        carries (branch pipes, hoses beyond the bore), which add capacitance but no
        inertance.
    diameter : float
        Bore diameter, m.
    roughness : float
        Wall roughness, m.
    viscosity : float
        Dynamic viscosity of air, Pa s (:func:`air_viscosity` of the temperature:
        1.81e-5 at 20 C); 0 switches wall friction off (an inviscid pipe, for tests).
    conductivity : float
        Thermal conductivity of air, W/(m K) (:func:`air_conductivity`: 0.0257 at 20 C);
        0 switches the wall's heat off (as the adiabatic mode).
    leak_cd_area : float64[nc]
        Discharge coefficient times area of each cell's leak to atmosphere, m^2 (0:
        tight).
    gamma, r_gas, temperature, atmosphere, r_lin : float
        Ratio of specific heats (-), gas constant (J/(kg K)), the wall's (and valves')
        temperature (K), atmospheric pressure (Pa, absolute) and the orifice law's
        linear-region ratio (-), as for
        :func:`ltdsim.physics.air.pneumatics.orifice_flow`.
    thermal : int
        :data:`THERMAL_WALL`, :data:`THERMAL_ADIABATIC` or :data:`THERMAL_ISOTHERMAL`.
    dp : float64[nc]
        Written: dp/dt, Pa/s.
    dq : float64[nc - 1]
        Written: dq/dt, kg/s^2.
    drho : float64[nc]
        Written: d(rho)/dt, kg/(m^3 s).

    Allocates nothing; safe to call inside a compiled right-hand side."""
    (area, dx_cell, dx_face, volume, diameter, roughness, viscosity, conductivity,
     leak_cd_area) = pipe
    gamma, r_gas, temperature, atmosphere, r_lin, thermal = gas
    nc = p.shape[0]
    iso = thermal == THERMAL_ISOTHERMAL
    cp = gamma * r_gas / (gamma - 1.0)
    heat = thermal == THERMAL_WALL and conductivity > 0.0
    # a cell's wall heat per kelvin and unit Nusselt number, W/K (half from each side)
    wall = 0.5 * conductivity * math.pi if heat else 0.0
    leak_total = 0.0
    # the side: inflow, leak, their enthalpy (dp holds the energy rate, W, until the end)
    for i in range(nc):
        t_i = p[i] / (r_gas * rho[i])
        leak = orifice_flow(p[i], atmosphere, leak_cd_area[i], gamma, r_gas, t_i, r_lin)
        leak_total += leak
        drho[i] = inflow[i] - leak
        if not iso:
            dp[i] = cp * (temperature * feed[i] - t_i * (feed[i] - inflow[i] + leak))
    if heat:  # the closed ends: a face at rest
        dp[0] += wall * NU_LAMINAR * dx_cell[0] * (temperature - p[0] / (r_gas * rho[0]))
        dp[nc - 1] += wall * NU_LAMINAR * dx_cell[nc - 1] * (
            temperature - p[nc - 1] / (r_gas * rho[nc - 1]))
    if nc >= 2:
        rough = _rough_term(roughness / diameter)
        fric = viscosity / (2.0 * diameter * diameter)
        re_scale = diameter / (area * viscosity) if viscosity > 0.0 else 0.0
        prandtl = viscosity * cp / conductivity if conductivity > 0.0 else 0.0
        pr23 = prandtl ** (2.0 / 3.0)
        qc = 0.5 * q[0]  # cell 0: its closed end and face 0
        f_left = qc * qc / (rho[0] * area)
        t_left = p[0] / (r_gas * rho[0])
        for j in range(nc - 1):
            qj = q[j]
            t_right = p[j + 1] / (r_gas * rho[j + 1])
            # mass across the face
            drho[j] -= qj
            drho[j + 1] += qj
            # momentum: pressure force, convected momentum, wall friction
            qr = q[j + 1] if j + 1 < nc - 1 else 0.0
            qc = 0.5 * (qj + qr)
            f_right = qc * qc / (rho[j + 1] * area)
            rho_f = 0.5 * (rho[j] + rho[j + 1])
            rate = (area * (p[j] - p[j + 1]) - (f_right - f_left)) / dx_face[j]
            fr = 0.0
            nu = NU_LAMINAR
            if viscosity > 0.0:
                phi, nu = _phi_nu(abs(qj) * re_scale, rough, prandtl, pr23)
                fr = phi * fric * qj / rho_f
                rate -= fr
            dq[j] = rate
            f_left = f_right
            if not iso:
                # enthalpy carried at the upwind cell's temperature
                flux = cp * qj * (t_left if qj >= 0.0 else t_right)
                # the mechanical work's share: pressure work on the moving air and
                # friction's dissipation, half to each neighbour
                work = 0.5 * qj / (rho_f * area) * (area * (p[j + 1] - p[j])
                                                      + fr * dx_face[j])
                dp[j] += work - flux
                dp[j + 1] += work + flux
                if heat:
                    dp[j] += wall * nu * dx_cell[j] * (temperature - t_left)
                    dp[j + 1] += wall * nu * dx_cell[j + 1] * (temperature - t_right)
            t_left = t_right
    gm1 = gamma - 1.0
    rt_w = r_gas * temperature
    for i in range(nc):
        drho[i] /= volume[i]
        if iso:
            dp[i] = rt_w * drho[i]
        else:
            dp[i] *= gm1 / volume[i]
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


def cell_volumes(dx_cell, area: float, side_volume, cells_per_vehicle: int) -> np.ndarray:
    """Volume of every cell, m^3: the bore's ``area dx_cell`` (m^2 times m) and, spread
    evenly over a vehicle's ``cells_per_vehicle`` cells, that vehicle's side volume
    (``side_volume``, m^3 per vehicle, lead first: branch pipe, dirt collector, the
    valve's pipe-side passages, hoses beyond the bore)."""
    side = np.repeat(np.asarray(side_volume, dtype=float) / cells_per_vehicle,
                     cells_per_vehicle)
    return np.asarray(dx_cell, dtype=float) * area + side


def pipe_mass(rho, volume) -> float:
    """Air mass in the pipe, kg, at cell densities ``rho`` (kg/m^3) in cells of
    ``volume`` (m^3): ``sum rho V``."""
    return float(np.sum(np.asarray(rho) * np.asarray(volume)))


def sound_speed(gamma: float, r_gas: float, temperature: float, thermal: int = THERMAL_WALL,
                share: float = 1.0) -> float:
    """Speed of small pressure waves in the pipe, m/s: ``sqrt(gamma R T share)``, or
    ``sqrt(R T share)`` in the isothermal mode, with ``share`` the bore's part of the
    pipe's volume (``A dx / V``, -: the side volumes add capacitance, not inertance).
    ``gamma`` -, ``r_gas`` J/(kg K), ``temperature`` K."""
    k = 1.0 if thermal == THERMAL_ISOTHERMAL else gamma
    return math.sqrt(k * r_gas * temperature * share)


def highest_wavenumber(dx_cell, dx_face) -> float:
    """The pipe's highest acoustic frequency divided by the wave speed, 1/m (rad/s per
    m/s): the square root of the largest eigenvalue of the grid's second difference
    ``(1 / dx_i) ((p_{i+1} - p_i) / dx'_i - (p_i - p_{i-1}) / dx'_{i-1})`` with closed
    ends. That operator is similar (scaled by ``sqrt(dx_i)``) to a symmetric tridiagonal
    matrix, whose largest eigenvalue scipy finds directly; on a uniform grid it is
    ``(2 / dx) cos(pi / (2 nc))``. With side volumes pass a cell's volume over the bore
    area as its ``dx_cell`` (m) and take the bore's speed of sound: the acoustics are the
    same with that capacitance."""
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


def pipe_max_rate(p, q, rho, pipe, gas) -> float:
    """Upper bound of the largest |eigenvalue| of the pipe's rates linearised at the
    state ``p`` (Pa abs), ``q`` (kg/s), ``rho`` (kg/m^3), 1/s (``pipe`` and ``gas`` as for
    :func:`pipe_rates`).

    Without flow the linearised pipe is, in its energy norm, a skew-symmetric acoustic
    part (frequencies up to ``omega = c`` times :func:`highest_wavenumber` of the cells'
    volumes over the bore, rad/s) plus a damping: friction's ``d(dq/dt)/dq`` per face,
    each leak's ``k R T G / V`` per cell (``k`` gamma, or 1 isothermal) and the wall's heat
    ``(gamma - 1) Nu k_air pi dx / (V R rho)`` per cell, 1/s; every eigenvalue then lies
    within ``sqrt(omega^2 + d^2)`` of the origin, ``d`` the largest face's and the largest
    cell's damping added (in fast flow they meet in one real mode). A flow ``u`` raises the acoustic
    part to ``(c + k |u|_max)`` times the bound (the characteristic speeds ``u +- c``; the
    energy balance advects the pressure with the enthalpy at up to ``gamma u``), and a
    pressure difference across a face, its friction and its cells' departure from the
    wall's temperature add to ``c^2`` (the energy balance couples the face's flow to its
    cells' pressures through the mechanical work's share and through the wall's heat,
    whose Nusselt number grows with the flow: ``gamma - 1`` times ``(|dp| / 2 + |fr| dx' /
    A) / rho + k pi dx |T_w - T| |dNu/dq| / 2``). For
    the step check: an explicit method is stable on the pipe when ``h`` times this rate
    lies inside its stability region along the worst ray (the imaginary axis is the safe
    choice)."""
    (area, dx_cell, dx_face, volume, diameter, roughness, viscosity, conductivity,
     leak_cd_area) = pipe
    gamma, r_gas, temperature, _, r_lin, thermal = gas
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    rho = np.asarray(rho, dtype=float)
    volume = np.asarray(volume, dtype=float)
    dx_cell = np.asarray(dx_cell, dtype=float)
    temp = p / (r_gas * rho)
    kappa = 1.0 if thermal == THERMAL_ISOTHERMAL else gamma
    rho_face = 0.5 * (rho[:-1] + rho[1:])
    u_max = float(np.max(np.abs(q) / (rho_face * area))) if q.size else 0.0
    c2 = kappa * r_gas * float(np.max(temp))
    cp = gamma * r_gas / (gamma - 1.0)
    prandtl = viscosity * cp / conductivity if conductivity > 0.0 else 0.0
    rel = roughness / diameter
    if thermal != THERMAL_ISOTHERMAL and q.size:
        # the energy balance couples a face's flow to its cells' pressures beyond the
        # enthalpy it carries: through the mechanical work's share (the pressure
        # difference across the face, and the friction's work, whose slope in q is at
        # most twice the friction force), and through the wall's heat, whose Nusselt
        # number grows with the flow; each adds (gamma - 1) times its slope in q (J/kg)
        # to c^2 (0 at rest in a uniform pipe at the wall's temperature)
        extra = 0.5 * np.abs(np.diff(p)) / rho_face
        if viscosity > 0.0:
            scale = diameter / (area * viscosity)
            re = np.abs(q) * scale
            fr = np.array([friction_phi(r, rel) for r in re]) * viscosity * np.abs(q) / (
                2.0 * diameter * diameter * rho_face)
            extra += fr * dx_face / (area * rho_face)
            if thermal == THERMAL_WALL and prandtl > 0.0:
                h = 1e-6 * re + 1e-3
                lo = np.maximum(re - h, 0.0)
                slope = np.abs([(nusselt(r + dr, rel, prandtl) - nusselt(r0, rel, prandtl))
                                / (r + dr - r0) for r, dr, r0 in zip(re, h, lo)]) * scale
                dtemp = np.abs(temperature - temp)
                extra += (0.5 * conductivity * math.pi * np.maximum(dx_cell[:-1], dx_cell[1:])
                          * np.maximum(dtemp[:-1], dtemp[1:]) * slope)
        c2 += (gamma - 1.0) * float(np.max(extra))
    c = math.sqrt(c2)
    # the characteristic speeds u +- c; the energy balance carries the pressure with the
    # flow's enthalpy at up to gamma u (its Jacobian in p and rho), so it takes that
    omega = (c + kappa * u_max) * highest_wavenumber(volume / area, dx_face)
    damp_face = 0.0  # friction's, on the faces' flows
    nu_face = np.full(q.size, NU_LAMINAR)
    if viscosity > 0.0 and q.size:
        scale = diameter / (area * viscosity)
        for j, (qj, rf) in enumerate(zip(q, rho_face)):
            re = abs(qj) * scale
            h = 1e-6 * re + 1e-3  # slope of phi(Re) Re by a central difference
            lo = max(re - h, 0.0)
            slope = ((re + h) * friction_phi(re + h, rel) - lo * friction_phi(lo, rel)) / (
                re + h - lo)
            damp_face = max(damp_face, viscosity * slope / (2.0 * diameter * diameter * rf))
            if prandtl > 0.0:
                nu_face[j] = nusselt(re, rel, prandtl)
    # the leaks' and the wall heat's, on the cells' pressures
    damp_cell = np.array([kappa * r_gas * temp[i] * orifice_conductance(
        cda, gamma, r_gas, temp[i], r_lin) / v for i, (cda, v) in enumerate(
            zip(np.asarray(leak_cd_area, dtype=float), volume))])
    if thermal == THERMAL_WALL and conductivity > 0.0:
        ends = np.concatenate([[NU_LAMINAR], nu_face, [NU_LAMINAR]])
        nu_cell = 0.5 * (ends[:-1] + ends[1:])
        damp_cell = damp_cell + ((gamma - 1.0) * nu_cell * conductivity * math.pi * dx_cell
                                 / (volume * r_gas * rho))
    # (a damped mode of faces and cells together can take both: with fast flow the heat
    # and the friction meet in one real mode)
    damp = damp_face + float(np.max(damp_cell))
    return math.sqrt(omega * omega + damp * damp)
