"""Modal analysis of a train linearised at a coupler stiffness (paper §5.2, Fig. 8).

The train is a free chain: masses ``m_i`` (kg) joined by springs ``k_j`` (N/m). Its
natural frequencies and mass-normalised mode shapes solve ``K phi = w^2 M phi``
(``scipy.linalg.eigh``). A free train has exactly one rigid-body mode at 0 Hz.

The study linearises at the simplified coupler's recoil stiffness ``k1`` ("low") and
at ``k2 + k3`` ("high"). A coupling has a draft gear at each wagon end, so two gears
act in series (``series = 2`` halves the stiffness of each coupling).
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


def coupling_stiffness(scenario: Scenario, which: str = "low", series: int = 2) -> np.ndarray:
    """Linearised stiffness of every coupling, N/m.

    ``which``: "low" (recoil k1 of a simplified coupler), "high" (k2 + k3), or a number
    (N/m, every coupler). Linear couplers use their stiffness either way. ``series``
    gears per coupling act in series.
    """
    from ltdsim.coupler_models import linearised_stiffness

    out = []
    for j in range(scenario.n_couplers):
        c = scenario.coupler(j)
        k = float(which) if not isinstance(which, str) else linearised_stiffness(c, which)
        if k is None:
            raise ValueError(f"coupler {j} is {c.model!r}: give a stiffness in N/m to linearise it")
        out.append(k / series)
    return np.array(out)


def train_modes(scenario: Scenario, which: str = "low", series: int = 2,
                lead: str = "free") -> pd.DataFrame:
    """Table of the train's modes: frequency (Hz) and mode shape per vehicle."""
    m = [v.mass for v in scenario.vehicles]
    f, phi = chain_modes(m, coupling_stiffness(scenario, which, series), lead)
    # sign convention: the lead vehicle's entry positive (or the first nonzero one)
    for i in range(phi.shape[1]):
        nz = np.flatnonzero(np.abs(phi[:, i]) > 1e-12)
        if nz.size and phi[nz[0], i] < 0:
            phi[:, i] *= -1
    table = pd.DataFrame(phi.T, columns=[f"vehicle_{i}" for i in range(len(m))])
    table.insert(0, "frequency_hz", f)
    table.index.name = "mode"
    return table


def save_mode_shapes(table: pd.DataFrame, path, title: str = ""):
    """Mode-shape figure (the study's Fig. 8): one panel per mode (the rigid-body mode of
    a free train left out), its amplitude along the train, normalised to the largest,
    with its frequency; ``title`` should say which stiffness was used."""
    from ltdsim.plotting import WIDTH, _save, plt

    modes = table[table.frequency_hz > 1e-6]
    shapes = modes.drop(columns="frequency_hz").values
    n = shapes.shape[1]
    cols = 3 if len(modes) > 4 else max(len(modes), 1)
    rows = -(-len(modes) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(WIDTH, 2.2 * rows + 1.0), squeeze=False,
                             sharex=True, sharey=True, constrained_layout=True)
    x = np.arange(1, n + 1)
    for k, (row, f) in enumerate(zip(shapes, modes.frequency_hz)):
        ax = axes.flat[k]
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.plot(x, row / np.abs(row).max(), "o-", ms=4, lw=1.2, color="tab:blue")
        ax.set_title(f"mode {k + 1}: {f:.2f} Hz", loc="left")
        ax.set_ylim(-1.15, 1.15)
        ax.xaxis.set_major_locator(plt.MaxNLocator(integer=True))
    for ax in axes.flat[len(modes):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("vehicle (1 = lead)")
    for ax in axes[:, 0]:
        ax.set_ylabel("displacement [-]")
    fig.suptitle(title or "mode shapes")
    return _save(fig, path)
