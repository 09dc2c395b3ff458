"""Explicit Runge-Kutta methods given by their Butcher tableaux.

Each method is ``(A, b, c, order)``; one generic compiled stage routine (in
:mod:`ltdsim.engine.kernel`) serves them all, as in SciPy's ``_ivp/rk.py``. Every tableau
here has ``c[0] = 0``, so the first stage is the right-hand side at the start of the
step, which the kernel records for free.

The embedded pair :data:`BS23` (Bogacki-Shampine 3(2), ``solver.method = "bs23"``) adds
the error weights ``e``: the difference of its third- and second-order solutions over
a step of size ``h`` is ``h * sum_i e_i K_i``, over its three stages and the
right-hand side at the step's end (first same as last: that evaluation is the next
step's first stage). SciPy's ``RK23`` holds the same weights with the opposite sign.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Tableau:
    """Butcher tableau of an explicit Runge-Kutta method."""

    name: str
    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    order: int
    #: error weights of an embedded pair (third minus second order for bs23), one per
    #: stage plus one for the right-hand side at the step's end; None for a fixed-step
    #: method
    e: np.ndarray | None = None

    @property
    def stages(self) -> int:
        return len(self.b)


def _t(name, A, b, c, order, e=None) -> Tableau:
    return Tableau(name, np.array(A, dtype=float), np.array(b, dtype=float),
                   np.array(c, dtype=float), order,
                   None if e is None else np.array(e, dtype=float))


TABLEAUX: dict[str, Tableau] = {
    "euler": _t("euler", [[0.0]], [1.0], [0.0], 1),
    "heun": _t("heun", [[0.0, 0.0], [1.0, 0.0]], [0.5, 0.5], [0.0, 1.0], 2),
    # Bogacki-Shampine 3(2), the third-order solution (MATLAB/Simulink ode3).
    "ode3": _t(
        "ode3",
        [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [0.0, 0.75, 0.0]],
        [2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0],
        [0.0, 0.5, 0.75],
        3,
    ),
    "rk4": _t(
        "rk4",
        [[0.0, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0], [0.0, 0.5, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]],
        [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
        [0.0, 0.5, 0.5, 1.0],
        4,
    ),
}


#: Bogacki-Shampine 3(2) with its error weights ``b - b_hat``, ``b_hat = (7/24, 1/4, 1/3,
#: 1/8)`` the second-order weights (Bogacki & Shampine 1989); the adaptive kernel
#: (:func:`ltdsim.engine.kernel.run_adaptive`) steps with it
BS23 = _t("bs23", TABLEAUX["ode3"].A, TABLEAUX["ode3"].b, TABLEAUX["ode3"].c, 3,
          e=[-5.0 / 72.0, 1.0 / 12.0, 1.0 / 9.0, -1.0 / 8.0])


def get_tableau(name: str) -> Tableau:
    """Return the tableau of fixed-step method ``name`` (euler, heun, ode3, rk4)."""
    try:
        return TABLEAUX[name]
    except KeyError:
        raise ValueError(f"unknown method {name!r}; choose one of {sorted(TABLEAUX)}") from None
