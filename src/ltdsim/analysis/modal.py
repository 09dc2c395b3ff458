"""Modal analysis of the train the kernel simulates, linearised on one branch of its
couplings (paper §5.2, Fig. 8).

The train is a free chain: masses ``m_i`` (kg) joined by springs ``k_j`` (N/m). Its
natural frequencies and mass-normalised mode shapes solve ``K phi = w^2 M phi``
(``scipy.linalg.eigh``). A free train has exactly one rigid-body mode at 0 Hz.

Each spring is the coupling's own linearised stiffness
(:func:`ltdsim.engine.couplers.linearised_stiffness`): its model's tangent on the branch
it is linearised on, ``"draft"`` (tension: a simplified coupler's ``k2 + k3``, the study's
"high" case) or ``"buff"`` (compression: its recoil stiffness ``k1``, the study's "low"
case), divided by the coupling's ``gears`` in series, exactly as the kernel applies the
law (:func:`ltdsim.engine.couplers.coupler_force`). The study's "low" and "high" are
branch names here because for some of its cases (LHHL among them) the buff branch is the
stiffer one.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import linalg

from ltdsim.scenario import Scenario


def chain_stiffness(k) -> np.ndarray:
    """Stiffness matrix (N/m) of a free chain with spring ``k[j]`` between bodies j, j+1."""
    k = np.asarray(k, dtype=float)
    n = k.size + 1
    K = np.zeros((n, n))
    for j, kj in enumerate(k):
        K[j, j] += kj
        K[j + 1, j + 1] += kj
        K[j, j + 1] -= kj
        K[j + 1, j] -= kj
    return K


def chain_modes(masses, k, lead: str = "free"):
    """Natural frequencies (Hz, ascending) and mass-normalised mode shapes (columns).

    Parameters
    ----------
    masses : array, kg
    k : array, N/m, one spring per coupling (``len(masses) - 1``)
    lead : "free" or "held"
        "held" fixes the lead vehicle (a speed controller holding the locomotive's speed
        makes it act almost as a moving wall): its row and column are removed and its
        mode-shape entry is 0.
    """
    m = np.asarray(masses, dtype=float)
    K = chain_stiffness(k)
    if lead == "held":
        w2, sub = linalg.eigh(K[1:, 1:], np.diag(m[1:]))
        phi = np.vstack([np.zeros((1, sub.shape[1])), sub])
        return np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi), phi
    if lead != "free":
        raise ValueError(f"lead must be 'free' or 'held', got {lead!r}")
    w2, phi = linalg.eigh(K, np.diag(m))
    w2 = np.clip(w2, 0.0, None)  # the rigid-body mode comes out as +-1e-10 roundoff
    return np.sqrt(w2) / (2 * np.pi), phi


def coupling_stiffness(scenario: Scenario, branch="draft") -> np.ndarray:
    """Linearised stiffness of every coupling, N/m, as the kernel simulates it.

    ``branch``: "draft" or "buff" (each coupling's tangent on that branch, its gears in
    series: :func:`ltdsim.engine.couplers.linearised_stiffness`), or a number (N/m, every
    coupling).
    """
    from ltdsim.engine.couplers import linearised_stiffness

    if not isinstance(branch, str):
        k = np.asarray(branch, dtype=float)
        return np.full(scenario.n_couplers, float(k)) if k.ndim == 0 else k
    out = []
    for j in range(scenario.n_couplers):
        c = scenario.coupler(j)
        k = linearised_stiffness(c, branch)
        if k is None:
            raise ValueError(f"coupler {j + 1} is {c.model!r}: give a stiffness in N/m "
                             "to linearise it")
        out.append(k)
    return np.array(out)


def operating_stiffness(scenario: Scenario, deflections) -> np.ndarray:
    """Tangent stiffness of every coupling at rest at the coupling deflections
    ``deflections`` (m from neutral, + draft, one per coupling; e.g. each coupler's mean
    over a steady stretch of a run), N/m, its gears in series
    (:func:`ltdsim.engine.couplers.operating_stiffness`). Pass the result to
    :func:`train_modes` as ``branch`` to get the modes about that state."""
    from ltdsim.engine.couplers import operating_stiffness as tangent

    d = np.asarray(deflections, dtype=float)
    if d.shape != (scenario.n_couplers,):
        raise ValueError(f"need one deflection per coupling ({scenario.n_couplers}), got "
                         f"{d.shape}")
    out = []
    for j in range(scenario.n_couplers):
        c = scenario.coupler(j)
        k = tangent(c, float(d[j]))
        if k is None:
            raise ValueError(f"coupler {j + 1} is {c.model!r}: its stiffness about a state "
                             "depends on its history; give a stiffness in N/m")
        out.append(k)
    return np.array(out)


def train_modes(scenario: Scenario, branch="draft", lead: str = "free") -> pd.DataFrame:
    """Table of the train's modes: frequency (Hz) and mode shape per vehicle, with every
    coupling linearised on ``branch`` (see :func:`coupling_stiffness`; an array gives
    each coupling's stiffness, N/m, e.g. from :func:`operating_stiffness`)."""
    m = [v.mass for v in scenario.vehicles]
    f, phi = chain_modes(m, coupling_stiffness(scenario, branch), lead)
    # sign convention: the lead vehicle's entry positive (or the first nonzero one)
    for i in range(phi.shape[1]):
        nz = np.flatnonzero(np.abs(phi[:, i]) > 1e-12)
        if nz.size and phi[nz[0], i] < 0:
            phi[:, i] *= -1
    table = pd.DataFrame(phi.T, columns=[f"vehicle_{i}" for i in range(len(m))])
    table.insert(0, "frequency_hz", f)
    table.index.name = "mode"
    return table


