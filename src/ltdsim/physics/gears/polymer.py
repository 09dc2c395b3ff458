"""Polymer (elastomer) draft gear: a rate-dependent stiffening spring with hysteresis.

A polymer gear is a stack of elastomer pads between a follower and the housing. Its
force rises more and more steeply as the pads are squeezed, it gives back less on
release than it took on loading (the polymer's internal losses, and in many designs
some friction), and it is stiffer the faster it is closed: the polymer is
viscoelastic. Wu, Luo, Qu and Yang (Vehicle System Dynamics 55(4), 2017, 501-516)
compare friction, polymer and friction-polymer gears and find the polymer gear soft at
the low working speeds of a running train and much stiffer in wagon impacts; Cole,
Spiryagin, Wu and Bosomworth (ICRT 2017, 413-423) model polymer gear connections in
longitudinal simulation with the gear's static characteristic plus frictional and
viscous components. ltdsim keeps the wagon-connection form of Cole's chapter in the
Handbook of Railway Vehicle Dynamics (and of the study's friction gear, paper Eq. 5-7):
a loading curve ``f_l``, an unloading curve ``f_u`` below it, the force clipped into
the band between them by one internal force ``F1`` (:func:`ltdsim.physics.gears.draftgear.
hysteresis`), and makes both curves functions of the closing speed. The functional
form below is ltdsim's choice (the papers above give the behaviour, not a closed form
that could be read here); docs/draftgear.md, "Polymer draft gear", gives the reasoning.

Static (quasi-static, closing speed 0) loading curve, a linear spring plus a power-law
stiffening, N, for gear deflection ``x >= 0`` (m)::

    f_s(x) = P + k0 x + (F_X - P - k0 X) (x / X)^n

with preload ``P`` (key ``preload``, N: the pads' pre-compression at assembly),
initial stiffness ``k0`` (``initial_stiffness``, N/m), static force ``F_X``
(``force_at_travel``, N) at the rated travel ``X`` (``travel``, m) and exponent
``n >= 1`` (``exponent``). Rate factors, -, of the closing speed ``v`` (m/s)::

    R_l(v) = 1 + a_l (1 - exp(-|v| / v_r))        R_u(v) = 1 + a_u (1 - exp(-|v| / v_r))

with gains ``a_l, a_u >= 0`` (``gain_loading``, ``gain_unloading``: the share by which
the curves rise at high speed, as the polymer turns from its rubbery towards its
glassy stiffness) and a rate speed ``v_r`` (``rate_speed``, m/s). The curves::

    f_l(x, v) = R_l(v) f_s(x)          f_u(x, v) = r R_u(v) f_s(x)

with the return ratio ``0 < r <= 1`` (``return_ratio``: the share of the static
loading force given back on release). So the loading stiffness ``R_l(v) f_s'(x)`` and
the unloading stiffness ``r R_u(v) f_s'(x)`` both rise with speed, from the static
curve at ``v = 0`` towards ``(1 + a) f_s'`` at impact speeds; a quasi-static closing
and release absorbs the share ``1 - r`` of the work done on the gear, and at speed
``v`` the share ``1 - r R_u(v) / R_l(v)``, which rises with speed when ``a_u < a_l``.
``f_u <= f_l`` everywhere needs ``r <= 1`` and ``r a_u <= a_l``. The exponential fade
has a finite slope at ``v = 0`` (``a / v_r`` per m/s): the speed dependence acts like a
damper of coefficient ``a f_s(x) / v_r`` (N s/m) near rest, which a fixed-step
explicit integrator can step, unlike a power law ``|v|^m`` with ``m < 1``.

The released gear (in its slack) extends to its preload: the released force is
``f_l(0, 0) = P``. Past the travel the kernel adds the solid gear
(:func:`ltdsim.physics.gears.couplers.solid_closure`) to both curves, as for every gear.

All functions take magnitudes: ``x = |e| >= 0`` and ``v = d|e|/dt`` (> 0 while the gear
closes). The parameters are data (a preset file or scenario keys), never literals here.
"""

from __future__ import annotations

from numba import njit

from ltdsim.physics.decay import exp_neg
from ltdsim.physics.gears.draftgear import gear_force


@njit(cache=True, inline="always")
def polymer_static(x, preload, initial_stiffness, force_at_travel, travel, exponent):
    """Static loading force ``f_s(x)`` (N) and its slope ``df_s/dx`` (N/m).

    ``f_s(x) = P + k0 x + (F_X - P - k0 X) (x / X)^n``.

    Parameters
    ----------
    x : float
        Gear deflection, m (>= 0).
    preload : float
        ``P``, force at zero deflection, N.
    initial_stiffness : float
        ``k0``, slope at zero deflection, N/m.
    force_at_travel : float
        ``F_X``, static force at the rated travel, N (``>= P + k0 X``).
    travel : float
        ``X``, rated travel, m (> 0).
    exponent : float
        ``n``, stiffening exponent, - (>= 1).
    """
    u = x / travel if x > 0.0 else 0.0
    c = force_at_travel - preload - initial_stiffness * travel
    p = u ** (exponent - 1.0) if u > 0.0 else (1.0 if exponent == 1.0 else 0.0)
    return (preload + initial_stiffness * x + c * p * u,
            initial_stiffness + c * exponent * p / travel)


@njit(cache=True, inline="always")
def rate_factor(v, gain, rate_speed):
    """Rate factor ``R(v) = 1 + gain (1 - exp(-|v| / rate_speed))``, -.

    ``v`` closing speed, m/s (either sign: the magnitude counts); ``gain`` the relative
    rise at high speed, -; ``rate_speed`` the speed scale of the rise, m/s (> 0).
    """
    return 1.0 + gain * (1.0 - exp_neg(abs(v) / rate_speed))


@njit(cache=True, inline="always")
def polymer_curves(x, v, preload, initial_stiffness, force_at_travel, travel, exponent,
                   return_ratio, gain_loading, gain_unloading, rate_speed):
    """Loading and unloading forces ``(f_l, f_u)`` (N) of the polymer gear at deflection
    ``x`` (m) and closing speed ``v`` (m/s), and their slopes ``(df_l/dx, df_u/dx)``
    (N/m) at that speed.

    ``f_l = R_l(v) f_s(x)``, ``f_u = r R_u(v) f_s(x)`` (module docstring): ``f_s`` from
    :func:`polymer_static` (``preload`` N, ``initial_stiffness`` N/m, ``force_at_travel``
    N, ``travel`` m, ``exponent`` -), ``r = return_ratio`` (-), ``R_l``, ``R_u`` from
    :func:`rate_factor` with ``gain_loading``, ``gain_unloading`` (-) and ``rate_speed``
    (m/s). Without the
    solid closure (the kernel adds it to every gear).
    """
    fs, ss = polymer_static(x, preload, initial_stiffness, force_at_travel, travel, exponent)
    rl = rate_factor(v, gain_loading, rate_speed)
    ru = return_ratio * rate_factor(v, gain_unloading, rate_speed)
    return rl * fs, ru * fs, rl * ss, ru * ss


@njit(cache=True)
def polymer_gear(f1, x, v, curves, k_locked, rate, solid_stiffness):
    """One polymer gear in contact: its force and the rate of its internal force.

    Returns ``(F, dF1/dt)``: ``F`` (N, >= 0, a magnitude) and the rate of the internal
    force ``F1`` (N/s), from :func:`polymer_curves` with ``curves`` its parameters after
    ``x`` and ``v`` (``(preload, initial_stiffness, force_at_travel, travel, exponent,
    return_ratio, gain_loading, gain_unloading, rate_speed)``) and the part all
    hysteretic gears share, :func:`ltdsim.physics.gears.draftgear.gear_force` (the solid
    gear past its travel with ``solid_stiffness`` N/m, the band law with ``k_locked``
    N/m and ``rate`` the internal force's tracking rate 1/s): the same steps as the
    kernel takes, for a gear on its own (tests, rigs). ``x`` (m) and ``v`` (m/s) are
    magnitudes as in the module docstring.
    """
    (preload, initial_stiffness, force_at_travel, travel, exponent, return_ratio,
     gain_loading, gain_unloading, rate_speed) = curves
    f_l, f_u, s_l, s_u = polymer_curves(x, v, preload, initial_stiffness, force_at_travel,
                                        travel, exponent, return_ratio, gain_loading,
                                        gain_unloading, rate_speed)
    return gear_force(f1, f_l, f_u, s_l, s_u, v, x, travel, solid_stiffness, k_locked, rate)


__all__ = ["polymer_curves", "polymer_gear", "polymer_static", "rate_factor"]
