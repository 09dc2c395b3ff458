"""The figures of a make-up study's page (matplotlib, no screen needed), each saved as
PNG: the distribution of the runs' largest forces with the limits, the probability of
exceeding a force with its confidence band, where the largest forces occur, what the
make-ups are made of against their largest compressive force, and the fatigue damage
per coupler. Forces in kN, positions in m, every axis with its unit."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from ltdsim.makeup import results as mr  # noqa: E402

COLOURS = ("#1f5fa8", "#c0392b", "#2e8b57", "#8e44ad", "#d68910", "#566573")
_NAMES = {"lcf": "LCF (compressive)", "ltf": "LTF (tensile)"}


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def _limits(p) -> dict[str, list[tuple[float, str]]]:
    """The distinct limits of the wagon types per force: ``(kN, label)``."""
    out: dict[str, dict[float, list[str]]] = {"lcf": {}, "ltf": {}}
    for (name, state), (lcf, ltf) in p.study.limits.items():
        for key, v in (("lcf", lcf), ("ltf", ltf)):
            if v == v:
                out[key].setdefault(v / 1e3, []).append(f"{name} {state}")
    return {k: [(v, ", ".join(n)) for v, n in sorted(d.items())] for k, d in out.items()}


def _limit_lines(ax, limits, reach: float, y: float, va: str) -> None:
    """Dashed lines at the limits (kN) up to ``reach``; the others named in a corner."""
    off = []
    for v, who in limits:
        if v <= reach:
            ax.axvline(v, color="k", ls="--", lw=1)
            ax.annotate(f"limit {v:.0f} kN ({who})", (v, y), xycoords=("data", "axes fraction"),
                        rotation=90, va=va, ha="right", fontsize=8)
        else:
            off.append(f"{v:.0f} kN ({who})")
    if off:
        ax.text(0.99, 0.98, "limits beyond the axis:\n" + "\n".join(off), ha="right",
                va="top", transform=ax.transAxes, fontsize=8,
                bbox={"facecolor": "white", "edgecolor": "#999", "alpha": 0.9})


def distribution(p, ok: pd.DataFrame, path: Path) -> Path:
    """Histograms of the runs' largest LCF and LTF per manoeuvre, with the types' limits."""
    limits = _limits(p)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, key in zip(axes, mr.FORCES):
        col = f"max_{key}_kN"
        top, low = float(ok[col].max()), float(ok[col].min())
        shown = [v for v, _ in limits[key] if v <= 2.0 * top]
        edges = np.linspace(0.95 * low, max([top] + shown) * 1.03, 31)
        for c, (man, g) in zip(COLOURS, ok.groupby("manoeuvre", sort=False)):
            ax.hist(g[col], bins=edges, histtype="stepfilled", alpha=0.35, color=c,
                    label=f"{man} ({len(g)} runs)")
            ax.hist(g[col], bins=edges, histtype="step", color=c)
        _limit_lines(ax, limits[key], 2.0 * top, 0.5, "center")
        ax.set_xlabel(f"largest {_NAMES[key]} of a run [kN]")
        ax.set_ylabel("runs [-]")
        ax.yaxis.get_major_locator().set_params(integer=True)
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(alpha=0.3)
    return _save(fig, path)


def exceedance(p, ok: pd.DataFrame, path: Path) -> Path:
    """P(a run's largest force > F) against F with its Clopper-Pearson band."""
    conf = p.study.spec.confidence
    limits = _limits(p)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, key in zip(axes, mr.FORCES):
        col = f"max_{key}_kN"
        top = float(ok[col].max())
        for c, (man, g) in zip(COLOURS, ok.groupby("manoeuvre", sort=False)):
            f, prob, lo, hi = mr.exceedance_curve(g[col], conf)
            ax.fill_between(f, lo, hi, color=c, alpha=0.2, lw=0, step="post")
            ax.step(f, prob, where="post", color=c, label=f"{man} ({len(g)} runs)")
        _limit_lines(ax, limits[key], 1.05 * top, 0.5, "center")
        ax.set_xlabel(f"force F, {_NAMES[key]} [kN]")
        ax.set_ylabel("probability a run's largest force exceeds F [-]")
        ax.set_ylim(-0.02, 1.02)
        ax.legend(fontsize=8, title=f"{conf * 100:g} % band shaded", title_fontsize=8)
        ax.grid(alpha=0.3)
    return _save(fig, path)


def where(ok: pd.DataFrame, path: Path) -> Path:
    """Each run's largest LCF and LTF against the position of its coupler."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, key in zip(axes, mr.FORCES):
        for c, (man, g) in zip(COLOURS, ok.groupby("manoeuvre", sort=False)):
            ax.scatter(g[f"{key}_position_m"], g[f"max_{key}_kN"], s=14, color=c,
                       alpha=0.7, label=man)
        ax.set_xlabel("coupler's distance from the front of the train [m]")
        ax.set_ylabel(f"largest {_NAMES[key]} of a run [kN]")
        ax.set_xlim(left=0.0)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return _save(fig, path)


def features_figure(ok: pd.DataFrame, path: Path) -> Path:
    """Each run's largest LCF against its make-up's empties ahead of loads, longest run
    of empties and empties right ahead of a remote consist."""
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, (feat, label) in zip(axes, (
            ("empties_ahead_of_loads", "empties ahead of loads:\nshare of (empty, loaded) "
                                       "pairs [-]"),
            ("longest_empty_run", "longest run of neighbouring empties [wagons]"),
            ("empties_ahead_of_remote", "empties right ahead of a remote consist "
                                        "[wagons]"))):
        for c, (man, g) in zip(COLOURS, ok.groupby("manoeuvre", sort=False)):
            ax.scatter(g[feat], g["max_lcf_kN"], s=14, color=c, alpha=0.7, label=man)
        ax.set_xlabel(label)
        ax.set_ylabel("largest LCF of a run [kN]")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return _save(fig, path)


def fatigue_figure(fat: pd.DataFrame, path: Path) -> Path:
    """Median and largest damage per run of each coupler over the make-ups."""
    fig, ax = plt.subplots(figsize=(11, 4.2))
    for c, (man, g) in zip(COLOURS, fat.groupby("manoeuvre", sort=False)):
        g = g.sort_values("coupler")
        ax.plot(g.coupler, g.max_damage, color=c, lw=1.2, label=f"{man}: largest")
        ax.plot(g.coupler, g.median_damage, color=c, lw=1.0, ls="--", label=f"{man}: median")
    ax.set_yscale("symlog", linthresh=max(1e-12, float(fat.max_damage[fat.max_damage > 0]
                                                           .min()) if (fat.max_damage > 0)
                                         .any() else 1e-12))
    ax.set_xlabel("coupler (1 = behind the lead vehicle) [-]")
    ax.set_ylabel("Miner damage per run [-]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path)
