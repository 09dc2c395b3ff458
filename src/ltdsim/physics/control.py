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


#: the PID's state between samples (one numpy record): integrator state (the integral
#: of the speed error, m) and derivative-filter state (m/s)
PID_STATE = np.dtype([("integrator", np.float64), ("filter", np.float64)])


def pid_init() -> np.void:
    """Zero controller state: one ``PID_STATE`` record (a view into an array of one,
    updated in place by :func:`pid_step`)."""
    return np.zeros(1, dtype=PID_STATE)[0]


@njit(cache=True, inline="always")
def pid_step(error, state, kp, ki, kd, n, ts, integrator, filt):
    """Advance the discrete PID by one sample and return its output.

    Parameters
    ----------
    error : float
        Controller input at this sample (speed error ``v_ref - v``, m/s).
    state : numpy record of ``PID_STATE``
        Integrator and derivative-filter states (``state["integrator"]``,
        ``state["filter"]``); updated in place.
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
        y_i = state["integrator"]
        state["integrator"] = state["integrator"] + ts * error
    else:
        state["integrator"] = state["integrator"] + ts * error
        y_i = state["integrator"]
    # filtered derivative: u_d = N (D e - f), f = F_d(z) u_d
    if filt == 0:
        u_d = n * (kd * error - state["filter"])
    else:
        u_d = n * (kd * error - state["filter"]) / (1.0 + n * ts)
    state["filter"] = state["filter"] + ts * u_d
    return kp * error + ki * y_i + u_d
