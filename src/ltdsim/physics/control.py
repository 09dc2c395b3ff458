"""Discrete PID speed controller in the study's parallel form (paper §5).

``C(z) = P + I * F_i(z) + D * N / (1 + N * F_d(z))`` with the integrator ``F_i`` and
derivative filter ``F_d`` each forward Euler ``Ts / (z - 1)`` or backward Euler
``Ts z / (z - 1)``. The study uses forward Euler for the integrator and backward Euler
for the filter, N = 100, Ts = 1e-4 s. The output is the demanded acceleration, m/s^2,
when the input is the speed error, m/s. How the study's printed form is read:
docs/model.md#speed-controller.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Discretisation method codes used in the compiled arrays.
FORWARD_EULER = 0
BACKWARD_EULER = 1
METHODS = {"forward_euler": FORWARD_EULER, "backward_euler": BACKWARD_EULER}


def pid_init() -> np.ndarray:
    """Zero controller state ``[integrator state, derivative-filter state]``."""
    return np.zeros(2)


@njit(cache=True, inline="always")
def pid_step(error, state, kp, ki, kd, n, ts, integrator, filt):
    """Advance the discrete PID by one sample and return its output.

    Parameters
    ----------
    error : float
        Controller input at this sample (speed error ``v_ref - v``, m/s).
    state : ndarray, shape (>= 2,)
        ``state[0]`` integrator state, ``state[1]`` filter state; updated in place
        (further elements are left alone).
    kp, ki, kd : float
        Proportional (1/s), integral (1/s^2) and derivative (-) gains for a speed
        error in m/s and an output in m/s^2.
    n : float
        Derivative filter coefficient, 1/s.
    ts : float
        Sample time, s.
    integrator, filt : int
        ``FORWARD_EULER`` (0) or ``BACKWARD_EULER`` (1) for the integrator and the
        derivative filter.

    Returns
    -------
    float
        Controller output (demanded acceleration, m/s^2).
    """
    # integral term: I * F_i(z) e
    if integrator == 0:
        y_i = state[0]
        state[0] = state[0] + ts * error
    else:
        state[0] = state[0] + ts * error
        y_i = state[0]
    # filtered derivative: u_d = N (D e - f), f = F_d(z) u_d
    if filt == 0:
        u_d = n * (kd * error - state[1])
    else:
        u_d = n * (kd * error - state[1]) / (1.0 + n * ts)
    state[1] = state[1] + ts * u_d
    return kp * error + ki * y_i + u_d
