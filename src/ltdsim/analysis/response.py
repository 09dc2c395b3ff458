"""Step and ramp response metrics of transfer functions (the study's Table 4).

Step metrics are python-control's ``step_info`` (rise time 10-90 %, settling within 2 %,
overshoot, peak, peak time, settling min/max); this module only adds the ramp
steady-state error and a helper for the study's Appendix II form (coefficients in
powers of ``z^-1`` at Ts = 1e-4 s).
"""

from __future__ import annotations

import control
import numpy as np


def tf_from_z_inverse(numerator, denominator, ts: float):
    """Discrete transfer function from coefficients of ``z^0, z^-1, ...`` (Appendix II
    form, feed-through included), sample time ``ts`` (s)."""
    num = np.asarray(numerator, dtype=float)
    den = np.asarray(denominator, dtype=float)
    n = max(num.size, den.size)
    # multiply through by z^(n-1): powers of z^-1 become descending powers of z
    num = np.concatenate([num, np.zeros(n - num.size)])
    den = np.concatenate([den, np.zeros(n - den.size)])
    return control.tf(num, den, ts)


def step_metrics(sys, settling_threshold: float = 0.02, points: int = 200_001) -> dict:
    """python-control's ``step_info`` of ``sys`` (seconds, fractions of the final value).

    A continuous system is evaluated on ``points`` samples over python-control's own
    horizon: its default grid is coarse enough to misplace the peak by a few per cent.
    A discrete system uses its own samples.
    """
    if sys.isdtime():
        return dict(control.step_info(sys, SettlingTimeThreshold=settling_threshold))
    horizon = control.step_response(sys).time[-1]
    t = np.linspace(0.0, horizon, points)
    return dict(control.step_info(sys, T=t, SettlingTimeThreshold=settling_threshold))


def ramp_error(sys, t_end: float | None = None) -> float:
    """Steady-state error of the unit-ramp response, ``lim (t - y(t))`` (s for a unit
    DC gain system), from a simulated ramp long enough to settle; ``inf`` if the
    response does not settle (unstable, or DC gain other than 1)."""
    if not np.all(np.abs(control.poles(sys)) < 1.0 if sys.isdtime() else
                  np.real(control.poles(sys)) < 0.0):
        return float("inf")
    info = control.step_info(sys)
    settling = float(info["SettlingTime"])
    if t_end is None and not np.isfinite(settling):
        return float("inf")  # the step response never settles: no steady ramp error
    horizon = t_end or max(20.0 * settling, 1.0)
    if sys.isdtime():
        t = np.arange(int(np.ceil(horizon / sys.dt)) + 1) * sys.dt
    else:
        t = np.linspace(0.0, horizon, 20001)
    y = control.forced_response(sys, T=t, U=t).outputs
    err = t - y
    tail = err[int(0.9 * err.size):]
    if np.ptp(tail) > 1e-6 * max(1.0, np.abs(tail).max()):
        return float("inf")  # still drifting: no steady state (DC gain other than 1)
    return float(tail[-1])


def rank_responses(metrics: dict[str, dict], overshoot_tolerance: float = 1.0) -> list[str]:
    """Case names ordered best first by step response: least overshoot first (cases
    within ``overshoot_tolerance`` percentage points count as equal), then fastest
    (shortest settling time, then rise time). ``metrics`` maps case -> step_metrics."""
    def key(name):
        m = metrics[name]
        return (round(m["Overshoot"] / overshoot_tolerance), m["SettlingTime"], m["RiseTime"])

    return sorted(metrics, key=key)
