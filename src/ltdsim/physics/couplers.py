"""Coupler (draft gear) force laws.

Coupler ``i`` joins vehicle ``i`` and ``i + 1`` (0 = lead). Its deflection is
``d = x_i - x_(i+1)`` measured from the neutral position, positive in draft (train
stretched), negative in buff (bunched). The force is positive in tension.

Free play: a coupling with total slack ``s`` carries no force while ``|d| <= s / 2``.
Outside it the gear deflection is ``e = d - sign(d) s / 2`` and ``de/dt = dd/dt``.
With slack, the two sides are in unilateral contact: a gear in draft can only pull
(``T >= 0``) and a gear in buff can only push (``T <= 0``), so a damper cannot glue
separating faces together. Without slack the coupling is a continuous spring-damper.
"""

from __future__ import annotations


from numba import njit, vectorize

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


@vectorize(["float64(float64, float64, float64, float64, float64)"], cache=True)
def coupler_linear(d, dd, slack, stiffness, damping):
    """Linear spring-damper coupler with a slack dead band, N (+ tension).

    ``T = k e + c de/dt`` outside the dead band, 0 inside it.

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
    """
    h = 0.5 * slack
    if d > h:
        e = d - h
    elif d < -h:
        e = d + h
    elif slack > 0.0:
        return 0.0
    else:
        return damping * dd  # no slack and d == 0 exactly: only the damper acts
    return contact(stiffness * e + damping * dd, e, slack)


@njit(cache=True, inline="always")
def simplified_force(d, dd, slack, preload, damping, k1, k2, k3, inv_vc):
    """:func:`coupler_simplified` with the critical velocity given as its inverse
    ``inv_vc = 1 / v_c`` (s/m), as the kernel stores it (a multiplication in the inner
    loop instead of a division), N."""
    h = 0.5 * slack
    if d > h:
        e = d - h
        f = preload + (k3 + k2 * exp_neg(abs(dd) * inv_vc)) * e + damping * dd
    elif d < -h:
        e = d + h
        f = -preload + k1 * e + damping * dd
    elif slack > 0.0:
        return 0.0
    else:
        return damping * dd  # no slack and d == 0 exactly: only the damper acts
    return contact(f, e, slack)


@vectorize(
    ["float64(float64, float64, float64, float64, float64, float64, float64, float64, float64)"],
    cache=True,
)
def coupler_simplified(d, dd, slack, preload, damping, k1, k2, k3, v_c):
    """The study's simplified nonlinear coupler (paper Eq. 9), N.

    Draft (``e > 0``): ``T = P + (k3 + k2 exp(-|de/dt| / v_c)) e + b de/dt``.
    Buff (``e < 0``): ``T = -P + k1 e + b de/dt``. Zero inside the dead band.

    The nonlinear stiffness ``k2`` fades as the gear slides faster, like the
    static-to-kinetic friction law; ``|de/dt|`` keeps it from feeding energy in. Why Eq. 9
    is read this way: docs/model.md#simplified-coupler.

    Parameters
    ----------
    d : float or array
        Coupler deflection from neutral, m (+ draft).
    dd : float or array
        Deflection rate, m/s.
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
        Critical velocity, m/s.
    """
    return simplified_force(d, dd, slack, preload, damping, k1, k2, k3, 1.0 / v_c)
