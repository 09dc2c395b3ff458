"""Transfer-function identification from recorded signals (paper §5.1, Table 3, App. II).

A discrete output-error model with feed-through,

    y[k] = B(q) / A(q) u[k] + e[k],   B = b0 + b1 q^-1 + ... + b_nb q^-nb,
                                      A = 1 + a1 q^-1 + ... + a_na q^-na

(the study: 4 poles, 3 zeros, so ``na = 4``, ``nb = 3``), is estimated by
prediction-error minimisation: an ARX least-squares start, refined by instrumental
variables (the ARX model's own simulated output as instruments, which removes ARX's
noise bias), then the output-error sum of squares minimised by
``scipy.optimize.least_squares`` (trust-region Gauss-Newton). The first half of the
record estimates, the second half validates.

Reported like the study's Table 3: FPE, MSE (estimation), fit % (validation; the
model simulated from the input alone, and also the one-step-ahead prediction fit),
function evaluations, final cost, norm of the step still left at the solution (the
Gauss-Newton step ``||J^+ r||``) and first-order optimality (``||J^T r||_inf``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import linalg, optimize, signal
from threadpoolctl import threadpool_limits


@dataclass
class Identified:
    """An identified discrete transfer function and how well it fits."""

    b: np.ndarray  # numerator, coefficients of z^0, z^-1, ... (Appendix II form)
    a: np.ndarray  # denominator, a[0] = 1
    dt: float  # sample time, s
    fpe: float
    mse: float  # mean squared residual on the estimation half
    fit_percent: float  # simulation fit on the validation half
    prediction_fit_percent: float  # one-step-ahead prediction fit, validation half
    evaluations: int
    cost: float  # 0.5 * sum of squared residuals (estimation), least_squares' cost
    step_norm: float
    optimality: float
    message: str = ""
    validation: dict = field(default_factory=dict, repr=False)

    @property
    def poles(self) -> np.ndarray:
        return np.roots(self.a)

    @property
    def zeros(self) -> np.ndarray:
        return np.roots(self.b) if np.any(self.b[1:]) else np.array([])

    def tf(self):
        """The model as a python-control transfer function."""
        from ltdsim.analysis.response import tf_from_z_inverse

        return tf_from_z_inverse(self.b, self.a, self.dt)


def _regressors(y, u, na, nb):
    n = len(y)
    k0 = max(na, nb)
    cols = [-y[k0 - i:n - i] for i in range(1, na + 1)]
    cols += [u[k0 - i:n - i] for i in range(0, nb + 1)]
    return np.column_stack(cols), y[k0:]


def arx(y, u, na: int, nb: int):
    """Least-squares ARX estimate ``(b, a)``."""
    phi, target = _regressors(y, u, na, nb)
    theta = linalg.lstsq(phi, target)[0]
    return theta[na:], np.concatenate([[1.0], theta[:na]])


def instrumental_variables(y, u, na: int, nb: int, iterations: int = 3):
    """ARX refined by instrumental variables: the instruments are the regressors built
    from the current model's noise-free simulated output."""
    b, a = arx(y, u, na, nb)
    for _ in range(iterations):
        if not _stable(a):
            break
        x = signal.lfilter(b, a, u)
        zeta, _ = _regressors(x, u, na, nb)
        phi, target = _regressors(y, u, na, nb)
        theta = linalg.lstsq(zeta.T @ phi, zeta.T @ target)[0]
        b, a = theta[na:], np.concatenate([[1.0], theta[:na]])
    return b, a


def _stable(a) -> bool:
    return bool(np.all(np.abs(np.roots(a)) < 1.0))


def fit_percent(y, y_hat) -> float:
    """Normalised fit, %: ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)``."""
    y = np.asarray(y, dtype=float)
    return float(100.0 * (1.0 - np.linalg.norm(y - y_hat) / np.linalg.norm(y - y.mean())))


def identify(u, y, dt: float, na: int = 4, nb: int = 3, max_nfev: int = 1000,
             tol: float = 1e-7) -> Identified:
    """Estimate an output-error model ``B/A`` (``na`` poles, ``nb`` zeros, feed-through)
    from input ``u`` and output ``y`` sampled every ``dt`` seconds; first half
    estimates, second half validates.
    """
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    half = len(y) // 2
    ue, ye, uv, yv = u[:half], y[:half], u[half:], y[half:]
    # scale to unit RMS so that the optimiser works on well-conditioned numbers
    su = np.sqrt(np.mean(ue**2)) or 1.0
    sy = np.sqrt(np.mean(ye**2)) or 1.0
    b0, a0 = instrumental_variables(ye / sy, ue / su, na, nb)
    if not _stable(a0):
        b0, a0 = arx(ye / sy, ue / su, na, nb)
    theta0 = np.concatenate([a0[1:], b0])

    def residual(theta):
        a = np.concatenate([[1.0], theta[:na]])
        with np.errstate(all="ignore"):
            out = ye / sy - signal.lfilter(theta[na:], a, ue / su)
        if not np.all(np.isfinite(out)) or np.abs(out).max() > 1e6:
            return np.full_like(out, 1e6)  # an unstable trial: a large, finite residual
        return out

    # one BLAS thread: the fit's linear algebra (an SVD of the Jacobian, thousands of
    # rows by na + nb + 1 columns, per iteration) ran 3x slower on OpenBLAS's threads
    # than on one, also alone on two cores (the study's LLHH case, 1000 evaluations:
    # 18 s against 6 s), and far slower still with two sweep workers side by side
    with threadpool_limits(limits=1, user_api="blas"):
        res = optimize.least_squares(residual, theta0, method="trf", xtol=tol, ftol=tol,
                                     gtol=tol, max_nfev=max_nfev)
    a = np.concatenate([[1.0], res.x[:na]])
    b = res.x[na:] * sy / su
    r = res.fun * sy
    n_par = na + nb + 1
    mse = float(np.mean(r**2))
    fpe = mse * (1 + n_par / half) / (1 - n_par / half)
    step = float(np.linalg.norm(linalg.lstsq(res.jac, res.fun)[0]))
    y_val = signal.lfilter(b, a, uv, zi=_initial_state(b, a, u[:half]))[0]
    fit = fit_percent(yv, y_val)
    pred = fit_percent(yv, one_step_prediction(b, a, u, y)[half:])
    return Identified(b=b, a=a, dt=dt, fpe=float(fpe), mse=mse, fit_percent=fit,
                      prediction_fit_percent=pred,
                      evaluations=int(res.nfev), cost=float(res.cost * sy**2),
                      step_norm=step, optimality=float(res.optimality),
                      message=str(res.message), validation={"y": yv, "y_hat": y_val})


def one_step_prediction(b, a, u, y) -> np.ndarray:
    """One-step-ahead prediction ``y_hat[k] = -sum a_i y[k-i] + sum b_j u[k-j]`` from
    measured past outputs (the equation-error predictor of the model's polynomials).
    At a sample time far below the dynamics it follows any smooth signal, which is why
    a prediction fit is not a model-quality measure there."""
    return y - signal.lfilter(a, [1.0], y) + signal.lfilter(b, [1.0], u)


def prediction_fit(u, y, na: int = 4, nb: int = 3) -> float:
    """One-step-ahead prediction fit (%, validation half) of an instrumental-variable
    model estimated on the first half: the "prediction focus" view, cheap at any
    sample time."""
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    half = len(y) // 2
    su = np.sqrt(np.mean(u[:half] ** 2)) or 1.0
    sy = np.sqrt(np.mean(y[:half] ** 2)) or 1.0
    b, a = instrumental_variables(y[:half] / sy, u[:half] / su, na, nb)
    return fit_percent(y[half:], sy * one_step_prediction(b, a, u / su, y / sy)[half:])


def _initial_state(b, a, u_past):
    """Filter state that continues the estimation half into the validation half (the
    model's own simulated output, so no measured output leaks into the validation)."""
    _, zf = signal.lfilter(b, a, u_past, zi=np.zeros(max(len(a), len(b)) - 1))
    return zf


def identify_result(ds, output: str = "acceleration", output_index: int = 1,
                    input_var: str = "traction_force", resample_dt: float | None = None,
                    na: int = 4, nb: int = 3, **kwargs) -> Identified:
    """Identify the transfer function from a result's ``input_var`` (default the
    locomotive force, N) to ``output`` (default the first wagon's acceleration, m/s^2),
    at the record's sample time or resampled to ``resample_dt`` (s) after an
    anti-aliasing filter (``scipy.signal.decimate``)."""
    dt = float(ds.time[1] - ds.time[0])
    u = ds[input_var].values
    y = ds[output].values
    if y.ndim == 2:
        y = y[:, output_index]
    if resample_dt is not None and resample_dt > dt * 1.5:
        q = int(round(resample_dt / dt))
        u = signal.decimate(u, q, ftype="fir", zero_phase=True)
        y = signal.decimate(y, q, ftype="fir", zero_phase=True)
        dt *= q
    return identify(u, y, dt, na, nb, **kwargs)
