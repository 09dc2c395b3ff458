"""End-of-car cushioning unit: a hydraulic cylinder whose piston strokes through an
orifice against a preloaded return spring, behind a stiff oil column.

Cushioned freight cars (automobile racks, boxcars for fragile loads) carry a hydraulic
unit in place of the draft gear, in the standard pocket and yoke, so that it is
compressed in buff and in draft alike. Its piston does not move until the force on it
passes the unit's preload (gas charge or valve preload: "retain a valve piston against a
seat until a preload pressure is reached", US patent 5,826,735); then oil is forced
through orifices whose resistance rises with the piston speed, over a long stroke
(AAR M-921 classes units by travel, 10 or 15 inches, against about 3-1/4 inches of a
friction gear), and a spring returns the piston to its seat once the force falls
(US patents of J. P. Monaco: a spring "to locate the piston in a neutral position").
In a 14 mph impact of 220,000 lb cars the force on such a unit reaches more than
1,000,000 lbf (4.4 MN) within milliseconds (US 5,826,735).

ltdsim's model, per gear, in the gear's own view (deflection beyond the slack
``x >= 0``, m, a magnitude: buff and draft alike; :func:`ltdsim.physics.gears.couplers.
gear_deflection`): one internal state, the piston's stroke ``s`` (m, ``0 <= s <=``
``travel``). The force on the unit is carried by the oil column, a stiff spring between
the coupler's follower and the piston::

    T = k_h max(x - s, 0)                                             (N)

with the oil column's stiffness ``k_h`` (key ``oil_stiffness``, N/m); the column
cannot pull, so a coupler that leaves the unit faster than the piston returns leaves it
unloaded. The piston (massless) moves when the column's force differs from the return
spring's, ``F_s(s) = P + k_s s`` (preload ``P``, ``preload``, N; spring stiffness
``k_s``, ``spring_stiffness``, N/m), at the speed at which the orifice's resistance

    F_o(u) = c_l u + c_q u |u|                                        (N)

(``orifice_linear`` c_l, N s/m: laminar; ``orifice_quadratic`` c_q, N s^2/m^2:
turbulent) takes up the difference, ``u = ds/dt = F_o^-1(T - F_s(s))``. Seated
(``s = 0``) the piston stays while ``T <= P``: the unit is rigid (the oil column alone)
below its preload. Near its seat and its stroke's end the piston is kept from passing
them: its speed is at most ``rate * s`` returning and ``rate * (travel - s)`` stroking,
with ``rate = (k_h + k_s) / c_l`` (1/s) the unit's fastest own rate (a time constant of
about a millisecond): the piston settles on its stops exponentially rather than
overshooting them, and an explicit step stays stable (the fixed-step check bounds the
step by ``1 / rate``). Past its travel the unit is solid: the oil column and the
coupling's solid closure carry the force.

The unit cannot create energy. It stores ``E = P s + k_s s^2 / 2 + k_h max(x - s, 0)^2
/ 2`` (J), and ``dE/dt = T dx/dt - (T - F_s) u``, where ``(T - F_s) u >= 0`` is the
power the orifice dissipates: ``u`` has the sign of ``T - F_s`` or is zero (the stops
only slow the piston). Below its preload, seated, it dissipates nothing.

The values of a preset are ltdsim's choices where the sources give only the behaviour
(``data/gears/eoc-15.toml`` says which is which).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def orifice_speed(force, linear, quadratic):
    """Piston speed (m/s, signed) at which the orifice resists with ``force`` (N):
    the inverse of ``F_o(u) = linear u + quadratic u |u|`` (``linear`` N s/m > 0,
    ``quadratic`` N s^2/m^2 >= 0), written ``2 F / (c_l + sqrt(c_l^2 + 4 c_q |F|))`` so
    that it holds without cancellation for small forces and for ``c_q = 0``."""
    return 2.0 * force / (linear + math.sqrt(linear * linear + 4.0 * quadratic * abs(force)))


@njit(cache=True, inline="always")
def cushion_force(x, s, oil_stiffness):
    """Force on the unit, N (a magnitude, >= 0): the oil column's ``k_h max(x - s, 0)`` at
    the gear deflection ``x`` (m, >= 0) and the piston's stroke ``s`` (m)."""
    return oil_stiffness * max(x - s, 0.0)


@njit(cache=True, inline="always")
def stroke_rate(force, s, preload, spring_stiffness, linear, quadratic, travel, rate):
    """The piston's speed ds/dt (m/s) under the unit's ``force`` (N, from
    :func:`cushion_force`) at the stroke ``s`` (m): seated while the force is at most the
    ``preload`` (N); otherwise the orifice's speed under the force less the return
    spring's ``preload + spring_stiffness s`` (N/m), at most ``rate * s`` returning and
    ``rate * (travel - s)`` stroking (``rate`` 1/s, ``travel`` m; see the module
    text)."""
    if s <= 0.0 and force <= preload:
        return -s * rate  # seated (a stroke below zero, a step's overshoot, goes back)
    u = orifice_speed(force - preload - spring_stiffness * s, linear, quadratic)
    if u < 0.0:
        return max(u, -s * rate)
    return min(u, (travel - s) * rate)


def stored_energy(x, s, preload, spring_stiffness, oil_stiffness):
    """Energy the unit stores at the gear deflection ``x`` and stroke ``s`` (m), J: the
    return spring's ``P s + k_s s^2 / 2`` and the oil column's ``k_h max(x - s, 0)^2 /
    2``."""
    return (preload * s + 0.5 * spring_stiffness * s * s
            + 0.5 * oil_stiffness * max(x - s, 0.0) ** 2)


def force_at_rest(x, preload, spring_stiffness, oil_stiffness, travel):
    """The unit's force at rest at the gear deflection ``x`` (m, an array or a number),
    N: the oil column alone, ``k_h x``, up to the preload; beyond it the piston has
    stroked to where the column and the return spring balance, ``s = (k_h x - P) / (k_h
    + k_s)``, at most its ``travel`` (m), and the force is ``k_h (x - s)``. What it gives
    back released slowly."""
    x = np.asarray(x, dtype=float)
    s = np.clip((oil_stiffness * x - preload) / (oil_stiffness + spring_stiffness), 0.0,
                travel)
    return oil_stiffness * (x - s)
