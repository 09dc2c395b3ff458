"""Explicit Runge-Kutta methods given by their Butcher tableaux.

Each method is ``(A, b, c, order)``; one generic compiled step (in
:mod:`ltdsim.kernel`) serves them all, as in SciPy's ``_ivp/rk.py``. Every tableau
here has ``c[0] = 0``, so the first stage is the right-hand side at the start of the
step, which the kernel records for free.
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

    @property
    def stages(self) -> int:
        return len(self.b)


def _t(name, A, b, c, order) -> Tableau:
    return Tableau(name, np.array(A, dtype=float), np.array(b, dtype=float),
                   np.array(c, dtype=float), order)


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


def get_tableau(name: str) -> Tableau:
    """Return the tableau of method ``name`` (euler, heun, ode3, rk4)."""
    try:
        return TABLEAUX[name]
    except KeyError:
        raise ValueError(f"unknown method {name!r}; choose one of {sorted(TABLEAUX)}") from None
