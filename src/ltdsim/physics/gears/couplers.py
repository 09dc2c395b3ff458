"""Coupler (draft gear) force laws.

Coupler ``i`` joins vehicle ``i`` and ``i + 1`` (0 = lead). Its deflection is
``d = x_i - x_(i+1)`` measured from the neutral position, positive in draft (train
stretched), negative in buff (bunched). The force is positive in tension.

Free play: a coupling with total slack ``s`` carries no force while ``|d| <= s / 2``.
Outside it the gear deflection is ``e = d - sign(d) s / 2`` and ``de/dt = dd/dt``.
With slack, the two sides are in unilateral contact: a gear in draft can only pull
(``T >= 0``) and a gear in buff can only push (``T <= 0``), so a damper cannot glue
separating faces together. Without slack the coupling is a continuous spring-damper.

Solid closure: a gear can travel only so far. Beyond its ``travel`` (m of gear
deflection past the slack) it closes solid and :func:`solid_closure` adds
``solid_stiffness * (|e| - travel)`` in the direction of the deflection. The hysteretic
gears (:mod:`ltdsim.physics.gears.draftgear`, through its ``gear_force``) and the linear and
simplified couplers use this same law; ``travel = inf`` is a gear without a stated limit.
A hysteretic gear first splits the coupler deflection with :func:`gear_deflection`.
"""

from __future__ import annotations


from numba import njit

from ltdsim.physics._lazy import vectorize_when_used

from ltdsim.physics.decay import exp_neg


@njit(cache=True, inline="always")
def contact(f, e, slack):
    """Unilateral contact across a slack coupling, N.

    With slack, a gear in draft (``e > 0``) can only pull and one in buff only push; a
    force of the wrong sign (a damper pulling separating faces together) becomes 0.
    Without slack the coupling is two-sided and ``f`` is returned unchanged.
    """
    if slack > 0.0 and f * e < 0.0:
        return 0.0
    return f


@njit(cache=True, inline="always")
def solid_closure(x, travel, stiffness):
    """Force added by a gear closed solid, N: ``stiffness * (x - travel)`` once the gear
    deflection ``x >= 0`` (m, a magnitude) passes its ``travel`` (m), else 0.
    ``stiffness`` (N/m) is the stiffness of the solid gear; ``travel = inf`` never
    closes."""
    return stiffness * max(x - travel, 0.0)  # (no inf x 0 when travel is inf)


@njit(cache=True, error_model="numpy")
def linear_force(d, dd, slack, stiffness, damping, travel, solid_stiffness):
    """:func:`coupler_linear` at one point, for compiled code: the kernels call it, the
    ufunc (compiled when first used) is for arrays. Same arguments and units."""
    h = 0.5 * slack
    if d > h:
        e = d - h
        f = stiffness * e + solid_closure(e, travel, solid_stiffness)
    elif d < -h:
        e = d + h
        f = stiffness * e - solid_closure(-e, travel, solid_stiffness)
    elif slack > 0.0:
        return 0.0
    else:
        return damping * dd  # no slack and d == 0 exactly: only the damper acts
    return contact(f + damping * dd, e, slack)


@vectorize_when_used(["float64(float64, float64, float64, float64, float64, float64, float64)"],
                     cache=True)
def coupler_linear(d, dd, slack, stiffness, damping, travel, solid_stiffness):
    """Linear spring-damper coupler with a slack dead band, N (+ tension).

    ``T = k e + c de/dt`` outside the dead band, 0 inside it; beyond ``travel`` the gear
    is solid (:func:`solid_closure`).

    Parameters
    ----------
    d : float or array
        Coupler deflection from neutral, m (+ draft).
    dd : float or array
        Deflection rate, m/s.
    slack : float
        Total free play, m.
    stiffness : float
        Spring stiffness ``k``, N/m.
    damping : float
        Viscous damping ``c``, N s/m.
    travel : float
        Gear deflection beyond the slack at which the gear goes solid, m (``inf``: none).
    solid_stiffness : float
        Stiffness of the solid gear beyond ``travel``, N/m.
    """
    return linear_force(d, dd, slack, stiffness, damping, travel, solid_stiffness)


@njit(cache=True, inline="always")
def simplified_force(d, dd, slack, preload, damping, k1, k2, k3, inv_vc, by_rate, travel,
                     solid_stiffness):
    """:func:`coupler_simplified` with the fade constant given as its inverse
    ``inv_vc = 1 / v_c`` (1/m, or s/m with ``by_rate``), as the kernel stores it (a
    multiplication in the inner loop instead of a division), N."""
    h = 0.5 * slack
    if d > h:
        e = d - h
        # the nonlinear stiffness fades with the gear deflection (the printed Eq. 9) or,
        # with ``by_rate``, with the deflection rate (an earlier reading; not passive)
        arg = abs(dd) if by_rate else e
        f = (preload + (k3 + k2 * exp_neg(arg * inv_vc)) * e + damping * dd
             + solid_closure(e, travel, solid_stiffness))
    elif d < -h:
        e = d + h
        f = -preload + k1 * e + damping * dd - solid_closure(-e, travel, solid_stiffness)
    elif slack > 0.0:
        return 0.0
    else:
        return damping * dd  # no slack and d == 0 exactly: only the damper acts
    return contact(f, e, slack)


@vectorize_when_used(
    ["float64(float64, float64, float64, float64, float64, float64, float64, float64, float64, "
     "boolean, float64, float64)"],
    cache=True,
)
def coupler_simplified(d, dd, slack, preload, damping, k1, k2, k3, v_c, by_rate, travel,
                       solid_stiffness):
    """The study's simplified nonlinear coupler (paper Eq. 9), N.

    Draft (``e > 0``): ``T = P + (k3 + k2 exp(-e / v_c)) e + b de/dt``, the equation as
    printed, with the nonlinear stiffness ``k2`` fading as the gear deflects (``v_c`` a
    length, m). With ``by_rate`` the fade follows the deflection rate instead,
    ``exp(-|de/dt| / v_c)`` (``v_c`` a speed, m/s): that reading can return more energy
    than it takes when a gear loads fast and unloads slowly (docs/model.md). Buff
    (``e < 0``): ``T = -P + k1 e + b de/dt``. Zero inside the dead band. Beyond ``travel``
    the gear is solid (:func:`solid_closure`).

    Parameters
    ----------
    d, dd : float or array
        Coupler deflection from neutral (m, + draft) and its rate (m/s).
    slack : float
        Total coupling clearance ``epsilon``, m.
    preload : float
        Gear preload ``P``, N.
    damping : float
        Damping ``b``, N s/m.
    k1 : float
        Recoil (buff) stiffness, N/m.
    k2 : float
        Nonlinear (draft) stiffness, N/m.
    k3 : float
        Linear (draft) stiffness, N/m.
    v_c : float
        Fade constant of ``k2``: a deflection, m (``by_rate`` False), or a critical
        velocity, m/s (``by_rate`` True).
    by_rate : bool
        The fade follows the deflection rate (True) or the deflection (False).
    travel : float
        Gear deflection beyond the slack at which the gear goes solid, m (``inf``: none).
    solid_stiffness : float
        Stiffness of the solid gear beyond ``travel``, N/m.
    """
    return simplified_force(d, dd, slack, preload, damping, k1, k2, k3, 1.0 / v_c, by_rate,
                            travel, solid_stiffness)


@njit(cache=True, inline="always")
def gear_deflection(d, dd, slack):
    """Split a coupler deflection into what a gear sees: ``(x, sign, in_slack)``.

    ``d`` is the coupler deflection from neutral (m, + draft), ``dd`` its rate (m/s),
    ``slack`` the total free play (m). Outside the slack the gear deflection is the
    magnitude ``x = |d| - slack / 2 >= 0`` (m) and ``sign`` is +1 in draft, -1 in buff.
    Inside a slack (``in_slack``) the gear is unloaded: ``x = 0``, ``sign = +1``. A
    coupling without slack at ``d = 0`` exactly takes the sign of the rate (the
    direction it is about to move). Every hysteretic gear applies this, then its own
    curves to ``x``, and returns ``sign x`` its force.
    """
    h = 0.5 * slack
    if d > h:
        return d - h, 1.0, False
    if d < -h:
        return -(d + h), -1.0, False
    if slack > 0.0:
        return 0.0, 1.0, True
    return 0.0, 1.0 if dd >= 0.0 else -1.0, False
