"""The coupler-model registry: one entry per coupler model, and the compiled dispatch.

A coupler model is four things:

1. its schema class in :mod:`ltdsim.scenario.couplers` (one member of the discriminated union on
   ``model``; its fields are the scenario keys, each with its unit);
2. its entry here (:class:`CouplerModel` in :data:`MODELS`): name, integer code, its own
   columns of the coupler table, how a validated coupler lowers into them (and into the
   table store), the kinds of its internal states, whether it is a hysteretic gear
   (internal force first), its released force (the initial internal force), its
   linearised stiffness for modal analysis, its stiffest tangent for the step-stability
   check, its force at rest on the way back (stored energy) and, for a law of the
   deflection and its rate alone, its tangent; plus its branch in :func:`coupler_force`
   (same file);
3. its force law in :mod:`ltdsim.physics`;
4. optionally preset data (``ltdsim/data/gears/*.toml``).

Coupler table layout. Every row starts with the columns all models share
(:data:`COMMON_COLUMNS`: slack, initial deflection, travel to solid, solid stiffness,
offset of its internal states in ``y``, relaxation rate of those states, released
force); each model's own columns follow at the same offset, overlapping those of the
other models, so the table is as wide as the common part plus the largest model's own
part. The column indices are module-level integers (numba freezes them as constants).
Only the engine (:mod:`ltdsim.engine.lowering`, :mod:`ltdsim.engine.kernel`, the gear rig through
:func:`lower_coupler`) reads this table.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numba import njit

from ltdsim.engine.features import when
from ltdsim.engine.layout import append_table, layout
from ltdsim.physics.gears.couplers import (
    gear_deflection,
    linear_force,
    simplified_force,
    solid_closure,
)
from ltdsim.physics.gears.cushion import cushion_force, force_at_rest, stroke_rate
from ltdsim.physics.gears.draftgear import (
    edge_structure,
    gear_force,
    plate_rate,
    plates_carried,
    plates_out,
    relax,
    s_table_lookup,
    table_curve,
    wedge_curves,
)
from ltdsim.physics.gears.polymer import polymer_curves

# ------------------------------------------------------------------ table layout
#: columns every coupler row has: total slack m, initial deflection (offset added to
#: x_j - x_(j+1)) m, gear travel beyond the slack to solid closure m (inf: none),
#: stiffness of the solid gear N/m, offset of the coupler's internal states among the
#: gear states (-1: none), their relaxation rate 1/s, force of the released gear at
#: zero deflection N (its internal force's initial value), and the inverse of the
#: number of gears in series in the coupling, - (each gear carries the coupling's force
#: and sees this share of its deflection and rate; its slack too, so that its dead band
#: is the coupling's: the model's laws take the gear's view, :func:`coupler_force`)
COMMON_COLUMNS = ("slack", "d0", "travel", "solid_stiffness", "state_offset", "rate",
                  "released_force", "inv_gears")
(P_SLACK, P_D0, P_TRAVEL, P_KSOLID, P_ZOFF, P_RATE, P_F0, P_INVG) = layout(*COMMON_COLUMNS)
N_COMMON = len(COMMON_COLUMNS)

#: linear: stiffness N/m, damping N s/m
LINEAR_COLUMNS = ("stiffness", "damping")
(LIN_STIFF, LIN_DAMP) = layout(*LINEAR_COLUMNS, start=N_COMMON)

#: simplified (paper Eq. 9): preload N, damping N s/m, k1 k2 k3 N/m, 1/v_c 1/m or s/m
#: (the kernel multiplies), whether k2 fades with the rate (1) or the deflection (0)
SIMPLIFIED_COLUMNS = ("preload", "damping", "k1", "k2", "k3", "inv_v_c", "by_rate")
(SIM_PRELOAD, SIM_DAMP, SIM_K1, SIM_K2, SIM_K3, SIM_IVC, SIM_RATE) = layout(
    *SIMPLIFIED_COLUMNS, start=N_COMMON)

#: columns every hysteretic gear has first among its own: locked stiffness N/m, and the
#: stiffness N/m (0: rigid) and damping N s/m of the structure in series with the gear
#: at the end of the slack (physics.gears.draftgear.edge_structure)
HYSTERETIC_COLUMNS = ("k_locked", "edge_stiffness", "edge_damping")
(HYS_KLOCK, HYS_KEDGE, HYS_CEDGE) = layout(*HYSTERETIC_COLUMNS, start=N_COMMON)

#: friction_wedge (paper Eq. 1-7): tan alpha, tan beta, tan gamma, G and the speed
#: ratios c1-c3 (physics.draftgear.wedge_geometry, -); friction h1 h2 -, h3 s/m;
#: lubrication factor S - or its table (offset in the table store, -1 none; numbers of
#: speeds and deflections); springs k_m N/m, x_m0 m, k_r N/m, x_r0 m; plate gap m,
#: plate backlash m
WEDGE_COLUMNS = HYSTERETIC_COLUMNS + (
    "tan_alpha", "tan_beta", "tan_gamma", "G", "c1", "c2", "c3", "h1", "h2", "h3", "S",
    "S_table", "S_n_velocity", "S_n_deflection", "k_m", "x_m0", "k_r", "x_r0",
    "plate_gap", "plate_backlash")
(_, _, _, WG_TA, WG_TB, WG_TG, WG_G, WG_C1, WG_C2, WG_C3, WG_H1, WG_H2, WG_H3, WG_S, WG_STAB, WG_SNV, WG_SNX,
 WG_KM, WG_XM0, WG_KR, WG_XR0, WG_GAP, WG_BACK) = layout(*WEDGE_COLUMNS, start=N_COMMON)

#: table: offsets and lengths of the loading and unloading curves in the table store
TABLE_COLUMNS = HYSTERETIC_COLUMNS + ("loading", "loading_len", "unloading",
                                      "unloading_len")
(_, _, _, TAB_LOAD, TAB_NLOAD, TAB_UNL, TAB_NUNL) = layout(*TABLE_COLUMNS, start=N_COMMON)

#: polymer (physics.polymer): static curve preload N, initial stiffness N/m, force at
#: the travel N, exponent -; return ratio -, rate gains on loading and unloading -,
#: rate speed m/s (the travel is the common column)
POLYMER_COLUMNS = HYSTERETIC_COLUMNS + ("preload", "initial_stiffness", "force_at_travel",
                                        "exponent", "return_ratio", "gain_loading",
                                        "gain_unloading", "rate_speed")
(_, _, _, POL_P, POL_K0, POL_FX, POL_N, POL_R, POL_AL, POL_AU, POL_VR) = layout(
    *POLYMER_COLUMNS, start=N_COMMON)

#: cushion (physics.gears.cushion): preload N, return spring N/m, oil column N/m, the
#: orifice's laminar N s/m and turbulent N s^2/m^2 resistance (its stroke is the common
#: travel, its piston's rate the common rate)
CUSHION_COLUMNS = ("preload", "spring_stiffness", "oil_stiffness", "orifice_linear",
                   "orifice_quadratic")
(CU_P, CU_KS, CU_KH, CU_CL, CU_CQ) = layout(*CUSHION_COLUMNS, start=N_COMMON)

#: model codes (the kernel's ``model`` array); the order of :data:`MODELS`
MODEL_NAMES = ("linear", "simplified", "friction_wedge", "table", "polymer", "cushion")
(M_LINEAR, M_SIMPLIFIED, M_WEDGE, M_TABLE, M_POLYMER, M_CUSHION) = layout(*MODEL_NAMES)


# ------------------------------------------------------------------ compiled dispatch
@njit(cache=True, _nrt=False, forceinline=True)
def _gear(j, model, d, dd, slack, y, zo, dy, dzo, cpl, ctab):
    """Force (N, + tension) of hysteretic gear ``j`` at its own deflection ``d`` (m),
    rate ``dd`` (m/s) and share of the slack ``slack`` (m) (:func:`coupler_force`);
    writes its state rates to ``dy``.

    ``zo``/``dzo`` index the gear's states in ``y``/``dy``: internal force F1 (N); for a
    wedge gear also the plate displacement p (m); with an S table also the impact speed
    v0 (m/s). What all hysteretic gears share (slack and sign, relaxation in the slack,
    solid closure, the hysteresis band) comes from :mod:`ltdsim.physics`; this function
    only picks each model's curves and its extra states.

    Compiled once for the train kernels and the gear rig (:mod:`ltdsim.analysis.gears`), inlined
    by LLVM (see :mod:`ltdsim.engine.kernel`'s notes on compiling).
    """
    x, sgn, in_slack = gear_deflection(d, dd, slack)
    rate = cpl[j, P_RATE]
    f1 = y[zo]
    wedge = model == M_WEDGE
    s_table = wedge and cpl[j, WG_STAB] >= 0.0
    if in_slack:
        # no force. The gear extends fully and its wedges come free, so it meets the next
        # load on its loading curve (F1 relaxes to the released force f_l(0)); the plates
        # go home; the impact speed follows the closing speed so that it holds its value
        # at contact. (States within 1e-12 of rest stop there: an endless exponential
        # decay ends in subnormal numbers, which are slow on every CPU.)
        dy[dzo] = relax(f1, cpl[j, P_F0], rate)
        if wedge:
            p = y[zo + 1]
            dy[dzo + 1] = plate_rate(-cpl[j, WG_GAP], p, 0.0, cpl[j, WG_BACK], rate) \
                if p > 1e-12 else 0.0
        if s_table:
            dy[dzo + 2] = relax(y[zo + 2], abs(dd), rate)
        return 0.0
    v = sgn * dd  # > 0 while the gear closes
    if wedge:
        p = y[zo + 1]
        gap = cpl[j, WG_GAP]
        delta = cpl[j, WG_BACK]
        off = int(cpl[j, WG_STAB])
        if off >= 0:
            s_factor = s_table_lookup(ctab, off, int(cpl[j, WG_SNV]), int(cpl[j, WG_SNX]),
                                      y[zo + 2], x)
        else:
            s_factor = cpl[j, WG_S]
        u = x - gap
        ramp = max(delta, 1e-3)  # plate friction fades in and out over this travel, m
        engaged = plates_out(p, ramp)
        f_l, f_u, s_l, s_u = wedge_curves(
            x, v, (cpl[j, WG_TA], cpl[j, WG_TB], cpl[j, WG_TG], cpl[j, WG_G], cpl[j, WG_C1],
                   cpl[j, WG_C2], cpl[j, WG_C3]), (cpl[j, WG_H1], cpl[j, WG_H2], cpl[j, WG_H3]),
            s_factor, (cpl[j, WG_KM], cpl[j, WG_XM0], cpl[j, WG_KR], cpl[j, WG_XR0]), engaged,
            engaged if plates_carried(u, p, delta) else 0.0)
    elif model == M_TABLE:
        f_l, s_l = table_curve(ctab, int(cpl[j, TAB_LOAD]), int(cpl[j, TAB_NLOAD]), x)
        f_u, s_u = table_curve(ctab, int(cpl[j, TAB_UNL]), int(cpl[j, TAB_NUNL]), x)
    elif model == M_POLYMER:
        f_l, f_u, s_l, s_u = polymer_curves(
            x, v, cpl[j, POL_P], cpl[j, POL_K0], cpl[j, POL_FX], cpl[j, P_TRAVEL],
            cpl[j, POL_N], cpl[j, POL_R], cpl[j, POL_AL], cpl[j, POL_AU], cpl[j, POL_VR])
    else:  # (no other hysteretic model: lowering gives only known codes)
        f_l = f_u = s_l = s_u = 0.0
    f, df1 = gear_force(f1, f_l, f_u, s_l, s_u, v, x, cpl[j, P_TRAVEL], cpl[j, P_KSOLID],
                        cpl[j, HYS_KLOCK], rate)
    f = edge_structure(f, x, v, cpl[j, HYS_KEDGE], cpl[j, HYS_CEDGE])
    dy[dzo] = df1
    if wedge:
        dy[dzo + 1] = plate_rate(x - cpl[j, WG_GAP], y[zo + 1], v, cpl[j, WG_BACK], rate)
    if s_table:
        dy[dzo + 2] = 0.0
    return sgn * f


@njit(cache=True, inline="always")
def _cushion(j, d, dd, slack, y, zo, dy, dzo, cpl):
    """Force (N, + tension) of cushioning unit ``j`` at its own deflection ``d`` (m), rate
    ``dd`` (m/s) and share of the slack ``slack`` (m) (:func:`coupler_force`); its
    piston's stroke (m) at ``y[zo]``, its rate to ``dy[dzo]``. In the slack the unit is
    unloaded and its piston returns."""
    x, sgn, in_slack = gear_deflection(d, dd, slack)
    s = y[zo]
    f = cushion_force(x, s, cpl[j, CU_KH])
    dy[dzo] = stroke_rate(f, s, cpl[j, CU_P], cpl[j, CU_KS], cpl[j, CU_CL], cpl[j, CU_CQ],
                          cpl[j, P_TRAVEL], cpl[j, P_RATE])
    return sgn * (f + solid_closure(x, cpl[j, P_TRAVEL], cpl[j, P_KSOLID]))


@njit(cache=True, inline="always")
def coupler_force(j, model, d, dd, y, z0, dy, dz0, cpl, ctab, kinds):
    """Force of coupler ``j`` (N, + tension) at deflection ``d`` (m) and rate ``dd``
    (m/s), by its model code ``model``. A gear with internal states reads them at
    ``y[z0 + offset]`` and writes their rates to ``dy[dz0 + offset]`` (``offset`` its
    ``P_ZOFF`` column). One branch per model of :data:`MODELS`; the hysteretic gears'
    and the cushioning units' branches are compiled only when ``kinds``
    (:class:`~ltdsim.engine.features.CouplerKinds`) says the train has them
    (otherwise they give 0 N, and no coupler takes them).

    A coupling of ``n`` gears in series (``P_INVG = 1 / n``): every gear carries the
    coupling's force, and alike gears from alike states share its deflection beyond the
    slack equally, so the law is evaluated once, at ``d / n`` and ``dd / n`` with the
    slack ``slack / n`` (the same dead band), and one set of internal states stands for
    all of them."""
    s = cpl[j, P_INVG]
    d = d * s
    dd = dd * s
    slack = cpl[j, P_SLACK] * s
    if model == M_SIMPLIFIED:
        return simplified_force(d, dd, slack, cpl[j, SIM_PRELOAD],
                                cpl[j, SIM_DAMP], cpl[j, SIM_K1], cpl[j, SIM_K2],
                                cpl[j, SIM_K3], cpl[j, SIM_IVC], cpl[j, SIM_RATE] > 0.0,
                                cpl[j, P_TRAVEL], cpl[j, P_KSOLID])
    if model == M_LINEAR:
        return linear_force(d, dd, slack, cpl[j, LIN_STIFF], cpl[j, LIN_DAMP],
                            cpl[j, P_TRAVEL], cpl[j, P_KSOLID])
    zo = int(cpl[j, P_ZOFF])
    if model == M_CUSHION:
        return when(kinds.cushion, _cushion, 0.0, j, d, dd, slack, y, z0 + zo, dy, dz0 + zo,
                    cpl)
    return when(kinds.hysteretic, _gear, 0.0, j, model, d, dd, slack, y, z0 + zo, dy,
                dz0 + zo, cpl, ctab)


# ------------------------------------------------------------------ registry
def _no_lag(c) -> None:
    """The lag of a model without internal states: none."""
    return None


@dataclass(frozen=True)
class CouplerModel:
    """One coupler model's entry in the registry (see the module text).

    ``lower(c, tables)`` returns the values of the model's own columns by name (and of
    common columns it sets itself, such as a table gear's travel), appending curves to
    the flat table store ``tables``; ``states(c)`` the kinds of its internal states
    ("force" N, "x" m, "v" m/s: they set the bs23 error weights); ``released(c)`` its
    initial internal force N; ``stiffness(c, branch)`` one gear's linearised stiffness N/m
    in the ``branch`` "draft" (tension) or "buff" (compression), for modal analysis, None
    when it has none; ``stiffest(c)`` one gear's tangent stiffness at its stiffest N/m,
    solid closure included (the fixed-step stability check, :mod:`ltdsim.engine.preflight`).
    These describe one gear: :func:`linearised_stiffness` and :func:`stiffest` give the
    coupling's, with its gears in series.
    """

    name: str
    columns: tuple[str, ...]
    lower: Callable[[object, list], dict]
    stiffest: Callable[[object], float]
    states: Callable[[object], tuple[str, ...]] = lambda c: ()
    released: Callable[[object], float] = lambda c: 0.0
    stiffness: Callable[[object, str], float | None] = lambda c, branch: None
    #: the most internal states any coupler of this model has
    max_states: int = 0
    #: a hysteretic gear: its first state is the internal force F1 of a band between a
    #: loading and an unloading curve (:func:`_gear`), whose error the adaptive kernel
    #: takes through the force the gear exerts
    hysteretic: bool = False
    #: ``at_rest(c, x, branch)``: one gear's force at rest on the way back (N) at its
    #: deflections ``x`` (m, magnitudes, an array) on ``branch``: what it gives back
    #: unloading slowly (:func:`stored_energy`)
    at_rest: Callable[[object, np.ndarray, str], np.ndarray] | None = None
    #: ``tangent(c, e)``: one gear's tangent stiffness at rest at its deflection ``e``
    #: (m beyond the slack, + draft), N/m, for a model whose force is a function of the
    #: deflection and its rate alone; None otherwise (:func:`operating_stiffness`)
    tangent: Callable[[object, float], float] | None = None
    #: ``lag(c)``: the fastest time constant of its internal states, ``(what, seconds)``
    #: (``what`` names the key or keys it comes from), None for a model without; the
    #: lowered row's relaxation rate ``rate`` is its inverse (1/s), and the fixed-step
    #: stability check bounds the step by it (:func:`ltdsim.engine.preflight.step_limit`)
    lag: Callable[[object], tuple[str, float] | None] = _no_lag

    @property
    def code(self) -> int:
        """The model's integer code in the kernel's ``model`` array."""
        return MODEL_NAMES.index(self.name)

    def column(self, name: str) -> int:
        """Index of column ``name`` (a common column or one of the model's own)."""
        if name in COMMON_COLUMNS:
            return COMMON_COLUMNS.index(name)
        return N_COMMON + self.columns.index(name)


def _lower_linear(c, tables) -> dict:
    return {"stiffness": c.stiffness, "damping": c.damping}


def _lower_simplified(c, tables) -> dict:
    return {"preload": c.preload, "damping": c.damping, "k1": c.k1, "k2": c.k2, "k3": c.k3,
            "inv_v_c": 1.0 / c.v_c, "by_rate": 1.0 if c.fade == "rate" else 0.0}


def _lower_wedge(c, tables) -> dict:
    from ltdsim.physics.gears.draftgear import wedge_geometry

    a, b, g = (np.radians(v) for v in (c.alpha_deg, c.beta_deg, c.gamma_deg))
    geometry = wedge_geometry(a, b, g)
    out = dict(zip(("tan_alpha", "tan_beta", "tan_gamma", "G", "c1", "c2", "c3"), geometry))
    out.update(k_locked=c.k_locked, h1=c.h1, h2=c.h2, h3=c.h3, k_m=c.k_m, x_m0=c.x_m0,
               k_r=c.k_r, x_r0=c.x_r0, plate_gap=c.plate_gap,
               plate_backlash=c.plate_backlash, S_table=-1.0)
    if c.S_table is not None:
        t = c.S_table
        out["S_table"] = append_table(tables, [*t.velocity, *t.deflection,
                                          *np.asarray(t.values, dtype=float).ravel()])
        out["S_n_velocity"], out["S_n_deflection"] = len(t.velocity), len(t.deflection)
    else:
        out["S"] = c.S
    return out


def _lower_table(c, tables) -> dict:
    out = {"k_locked": c.k_locked}
    for pts, name in ((c.loading, "loading"), (c.unloading, "unloading")):
        arr = np.asarray(pts, dtype=float)
        out[name] = append_table(tables, [*arr[:, 0], *arr[:, 1]])
        out[name + "_len"] = len(arr)
    # a table gear closes solid at its last point unless told otherwise
    last = max(c.loading[-1][0], c.unloading[-1][0])
    out["travel"] = c.travel if c.travel is not None else last
    return out


def _solid(c) -> float:
    """The solid gear's stiffness where the coupler closes solid (it has a travel), N/m."""
    return c.solid_stiffness if c.travel is not None else 0.0


def _curve_slope(points) -> float:
    """Steepest slope of a piecewise-linear ``[x m, F N]`` table, N/m."""
    xs, fs = np.asarray(points, dtype=float).T
    return float(np.max(np.abs(np.diff(fs) / np.diff(xs)))) if len(xs) > 1 else 0.0


@functools.lru_cache(maxsize=64)
def _wedge_slope(key: tuple) -> float:
    """Steepest slope of a wedge gear's quasi-static loading and unloading curves (at
    rest, where friction is largest), each stage with its plates engaged or not, N/m."""
    from ltdsim.physics.gears.draftgear import wedge_gear_quasistatic

    (alpha, beta, gamma, h1, h2, h3, s, k_m, x_m0, k_r, x_r0, gap, back, travel) = key
    x = np.linspace(0.0, travel, 201)
    steepest = 0.0
    for loading in (1.0, 0.0):
        for plates in (0.0, 1.0):
            f = wedge_gear_quasistatic(x, loading, np.radians([alpha, beta, gamma]),
                                       (h1, h2, h3), s, (k_m, x_m0, k_r, x_r0), gap, back,
                                       plates)
            steepest = max(steepest, float(np.max(np.abs(np.diff(f) / np.diff(x)))))
    return steepest


def _wedge_stiffest(c) -> float:
    s = c.S if c.S is not None else max(max(r) for r in c.S_table.values)
    return c.k_locked + _wedge_slope((c.alpha_deg, c.beta_deg, c.gamma_deg, c.h1, c.h2, c.h3,
                                      s, c.k_m, c.x_m0, c.k_r, c.x_r0, c.plate_gap,
                                      c.plate_backlash, c.travel)) + _solid(c)


def _wedge_states(c) -> tuple[str, ...]:
    # internal force; plate displacement; with an S table the impact speed
    return ("force", "x") + (("v",) if c.S_table is not None else ())


def _wedge_released(c) -> float:
    from ltdsim.physics.gears.draftgear import wedge_gear_quasistatic

    return float(wedge_gear_quasistatic(
        0.0, 1.0, np.radians([c.alpha_deg, c.beta_deg, c.gamma_deg]), (c.h1, c.h2, c.h3),
        c.S if c.S is not None else c.S_table.values[0][0], (c.k_m, c.x_m0, c.k_r, c.x_r0),
        c.plate_gap, c.plate_backlash, 0.0))


def _lower_polymer(c, tables) -> dict:
    return {name: float(getattr(c, name))
            for name in ("k_locked",) + POLYMER_COLUMNS[len(HYSTERETIC_COLUMNS):]}


def _polymer_stiffness(c, branch: str) -> float:
    """Linearised stiffness of a polymer gear, N/m, in either branch (the gear is the
    same in draft and buff): the slope of its static loading curve at zero deflection,
    ``initial_stiffness``."""
    return float(c.initial_stiffness)


def _polymer_stiffest(c) -> float:
    """Tangent at its stiffest: the locked stiffness on top of the loading curve's slope
    at the travel at high speed, and the solid gear, N/m."""
    from ltdsim.physics.gears.polymer import polymer_static

    _, s = polymer_static(c.travel, c.preload, c.initial_stiffness, c.force_at_travel,
                          c.travel, c.exponent)
    return c.k_locked + (1.0 + c.gain_loading) * s + c.solid_stiffness


def _simplified_tangent(c, e: float) -> float:
    """Tangent of a simplified gear at rest at gear deflection ``e`` (m, + draft, beyond
    the slack), N/m: buff k1; draft ``k3 + k2 exp(-e/v_c) (1 - e/v_c)`` when k2 fades with
    the deflection, ``k3 + k2`` when it fades with the rate (at rest it has not faded)."""
    if e < 0.0:
        return c.k1
    if c.fade == "rate":
        return c.k3 + c.k2
    z = e / c.v_c
    return c.k3 + c.k2 * np.exp(-z) * (1.0 - z)


def _simplified_at_rest(c, x, branch):
    if branch == "buff":
        return c.preload + c.k1 * x
    k2 = c.k2 * (np.exp(-x / c.v_c) if c.fade == "deflection" else 1.0)
    return c.preload + (c.k3 + k2) * x


def _wedge_unloading(c, x, branch):
    from ltdsim.physics.gears.draftgear import wedge_gear_quasistatic

    s = c.S if c.S is not None else c.S_table.values[0][0]
    return wedge_gear_quasistatic(x, 0.0, np.radians([c.alpha_deg, c.beta_deg, c.gamma_deg]),
                                  (c.h1, c.h2, c.h3), s, (c.k_m, c.x_m0, c.k_r, c.x_r0),
                                  c.plate_gap, c.plate_backlash, -1.0)


def _polymer_unloading(c, x, branch):
    from ltdsim.physics.gears.polymer import polymer_static

    f = np.array([polymer_static(xi, c.preload, c.initial_stiffness, c.force_at_travel,
                                 c.travel, c.exponent)[0] for xi in np.atleast_1d(x)])
    return c.return_ratio * f


def _lower_cushion(c, tables) -> dict:
    return {k: getattr(c, k) for k in CUSHION_COLUMNS}


def _cushion_lag(c) -> tuple[str, float]:
    """A cushioning unit's fastest own time constant, its piston's near the stops: the
    laminar orifice against the oil column and the return spring, s."""
    return ("orifice_linear / (oil_stiffness + spring_stiffness)",
            c.orifice_linear / (c.oil_stiffness + c.spring_stiffness))


def _tracking(c) -> tuple[str, float]:
    """A hysteretic gear's lag: its internal force tracks its curves within
    ``tracking_time`` (s)."""
    return ("tracking_time", c.tracking_time)


#: the registry, in code order (:data:`MODEL_NAMES`)
MODELS: tuple[CouplerModel, ...] = (
    CouplerModel("linear", LINEAR_COLUMNS, _lower_linear,
                 stiffest=lambda c: c.stiffness + _solid(c),
                 stiffness=lambda c, branch: c.stiffness,
                 at_rest=lambda c, x, branch: c.stiffness * x,
                 tangent=lambda c, e: c.stiffness),
    # simplified: buff k1; draft the tangent at rest and at zero deflection, k2 + k3 (either
    # fade: exp(-e/v_c) and exp(-|de/dt|/v_c) are both 1 there), the study's "high" (§5.2)
    CouplerModel("simplified", SIMPLIFIED_COLUMNS, _lower_simplified,
                 stiffest=lambda c: max(c.k1, c.k2 + c.k3) + _solid(c),
                 stiffness=lambda c, branch: c.k1 if branch == "buff" else c.k2 + c.k3,
                 at_rest=_simplified_at_rest, tangent=_simplified_tangent),
    CouplerModel("friction_wedge", WEDGE_COLUMNS, _lower_wedge, _wedge_stiffest,
                 states=_wedge_states, released=_wedge_released, max_states=3,
                 hysteretic=True, at_rest=_wedge_unloading, lag=_tracking),
    # (a table gear closes solid at its last point when it states no travel)
    CouplerModel("table", TABLE_COLUMNS, _lower_table,
                 lambda c: c.k_locked + max(_curve_slope(c.loading),
                                            _curve_slope(c.unloading)) + c.solid_stiffness,
                 states=lambda c: ("force",), released=lambda c: float(c.loading[0][1]),
                 max_states=1, hysteretic=True, lag=_tracking,
                 at_rest=lambda c, x, branch: np.interp(
                     x, *np.asarray(c.unloading, dtype=float).T)),
    # polymer: one internal state (its force); released at its preload; linearised at
    # the static loading slope at rest ("low") or at impact speeds ("high")
    CouplerModel("polymer", POLYMER_COLUMNS, _lower_polymer, states=lambda c: ("force",),
                 released=lambda c: float(c.preload),
                 stiffness=_polymer_stiffness, stiffest=_polymer_stiffest, max_states=1,
                 hysteretic=True, at_rest=_polymer_unloading, lag=_tracking),
    # cushion: one internal state, its piston's stroke (m); rigid below its preload, so
    # linearised on its oil column
    CouplerModel("cushion", CUSHION_COLUMNS, _lower_cushion,
                 stiffest=lambda c: c.oil_stiffness + _solid(c),
                 states=lambda c: ("x",), max_states=1,
                 stiffness=lambda c, branch: c.oil_stiffness, lag=_cushion_lag,
                 at_rest=lambda c, x, branch: force_at_rest(
                     x, c.preload, c.spring_stiffness, c.oil_stiffness, c.travel)),
)
REGISTRY: dict[str, CouplerModel] = {m.name: m for m in MODELS}
assert tuple(REGISTRY) == MODEL_NAMES, "MODELS must follow MODEL_NAMES (their codes)"
#: width of the coupler table: the common columns and the widest model's own
N_CCOL = N_COMMON + max(len(m.columns) for m in MODELS)
#: most internal states of one coupler
N_GEAR_STATES = max(m.max_states for m in MODELS)


@dataclass(frozen=True)
class LoweredCoupler:
    """One coupler as the kernel reads it (:func:`lower_coupler`)."""

    code: int  #: model code
    row: np.ndarray  #: (N_CCOL,) its row of the coupler table
    states: tuple[str, ...]  #: kinds of its internal states ("force", "x", "v", ...)
    y0: tuple[float, ...]  #: their initial values (N, m, m/s, ...)
    hysteretic: bool  #: a hysteretic gear, its internal force F1 first (CouplerModel)


def lower_coupler(c, tables: list[float], *, sign0: float = 0.0,
                  state_offset: int = 0) -> LoweredCoupler:
    """Lower one validated coupler ``c`` (a member of ``ltdsim.scenario.couplers.Coupler``).

    Appends its curves to the flat table store ``tables``. ``sign0`` is the initial state
    of the coupling (0 neutral, +1 stretched, -1 bunched: it starts at the end of its slack);
    ``state_offset`` where its internal states start among the gear states.
    """
    entry = REGISTRY[c.model]
    row = np.zeros(N_CCOL)
    row[P_SLACK] = c.slack
    row[P_D0] = sign0 * 0.5 * c.slack
    row[P_ZOFF] = -1.0
    # gear travel beyond the slack (a model may set its own default); a coupler without
    # one never closes solid
    row[P_TRAVEL] = np.inf if c.travel is None else c.travel
    row[P_KSOLID] = c.solid_stiffness
    row[P_INVG] = 1.0 / c.gears
    states = entry.states(c)
    y0: tuple[float, ...] = ()
    lag = entry.lag(c)
    if lag is not None:
        row[P_RATE] = 1.0 / lag[1]
    if states:
        row[P_ZOFF] = state_offset
        row[P_F0] = entry.released(c)
        # the internal force starts released, on the loading curve at 0; the others at 0
        y0 = (row[P_F0],) + (0.0,) * (len(states) - 1)
    for name, value in entry.lower(c, tables).items():
        row[entry.column(name)] = value
    if entry.hysteretic:  # the structure at the end of the slack (0: rigid)
        row[HYS_KEDGE] = edge_stiffness(c) or 0.0
        row[HYS_CEDGE] = c.edge_damping
    return LoweredCoupler(entry.code, row, states, y0, entry.hysteretic)


def edge_stiffness(c) -> float | None:
    """Stiffness of the structure in series with coupler ``c``'s gear at the end of its
    slack, N/m (a hysteretic gear's ``edge_stiffness``); None where the end is rigid."""
    return c.edge_stiffness if REGISTRY[c.model].hysteretic else None


def released_force(c) -> float:
    """Force of a released gear ``c`` at zero deflection on its loading curve, N (the
    initial value of its internal force; 0 for a model without one)."""
    return REGISTRY[c.model].released(c)


#: the branches a coupling can be linearised on: in tension or in compression
BRANCHES = ("draft", "buff")


def linearised_stiffness(c, branch: str = "draft") -> float | None:
    """Linearised stiffness of coupling ``c`` for modal analysis, N/m, on the ``branch``
    "draft" (tension; a simplified coupler's k2 + k3) or "buff" (compression; its recoil
    stiffness k1); a linear coupler's stiffness either way; None for a model without one
    (give a number instead). Its ``gears`` in series divide one gear's stiffness: the
    same coupling the kernel simulates (:func:`coupler_force`)."""
    if branch not in BRANCHES:
        raise ValueError(f"branch must be one of {', '.join(BRANCHES)}, got {branch!r}")
    k = REGISTRY[c.model].stiffness(c, branch)
    return None if k is None else k / c.gears


def operating_stiffness(c, d: float) -> float | None:
    """Tangent stiffness of coupling ``c`` at rest at the coupling deflection ``d`` (m from
    neutral, + draft, its slack included), N/m: 0 inside the slack; beyond it one gear's
    tangent at its share of the deflection, over the gears in series, plus the solid
    gear's stiffness past the travel. None for a hysteretic gear (its small-amplitude
    stiffness depends on where in its band it is). The small oscillations of a train
    about a steady state ring at the modes of these stiffnesses (:mod:`ltdsim.analysis.modal`)."""
    tangent = REGISTRY[c.model].tangent
    if tangent is None:
        return None
    h = 0.5 * c.slack
    if abs(d) <= h and c.slack > 0.0:
        return 0.0
    e = (d - h if d > 0.0 else d + h) / c.gears
    k = tangent(c, e)
    if c.travel is not None and abs(e) > c.travel:
        k += c.solid_stiffness
    return k / c.gears


def stored_energy(c, d: float, points: int = 201) -> float:
    """Energy coupling ``c`` stores at the coupling deflection ``d`` (m from neutral, +
    draft), J: what its gears give back released slowly to the end of the slack, the
    integral of each gear's force at rest on the way back (a hysteretic gear's unloading
    curve) over its share of the deflection, times the gears in series, plus the solid
    gear's part past the travel. 0 inside the slack. A hysteretic gear's structure at the
    end of the slack (``edge_stiffness``) caps that force by its spring's. A coupler's
    work since the start (``coupler_energy``) less this is what its gears have
    dissipated."""
    h = 0.5 * c.slack
    if abs(d) <= h and c.slack > 0.0:
        return 0.0
    x = (abs(d) - h) / c.gears
    branch = "draft" if d > 0.0 else "buff"
    xs = np.linspace(0.0, x, points)
    f = np.asarray(REGISTRY[c.model].at_rest(c, xs, branch), dtype=float)
    k_edge = edge_stiffness(c)
    if k_edge is not None:
        f = np.minimum(f, k_edge * xs)
    energy = float(np.trapezoid(f, xs))
    if c.travel is not None and x > c.travel:
        energy += 0.5 * c.solid_stiffness * (x - c.travel) ** 2
    return c.gears * energy


def fastest_lag(c) -> tuple[str, float] | None:
    """The fastest time constant of coupler ``c``'s internal states, ``(what, seconds)``,
    None for a model without (:attr:`CouplerModel.lag`)."""
    return REGISTRY[c.model].lag(c)


def stiffest(c) -> float:
    """Tangent stiffness of coupling ``c`` at its stiffest, N/m, solid closure and a
    hysteretic gear's structure at the end of the slack included: one gear's over its
    ``gears`` in series (the fixed-step stability check)."""
    return max(REGISTRY[c.model].stiffest(c), edge_stiffness(c) or 0.0) / c.gears


def _check_registry() -> None:
    for m in MODELS:
        if m.hysteretic and m.columns[:len(HYSTERETIC_COLUMNS)] != HYSTERETIC_COLUMNS:
            raise AssertionError(f"hysteretic model {m.name} must start with "
                                 f"{HYSTERETIC_COLUMNS}")
        if set(m.columns) & set(COMMON_COLUMNS):
            raise AssertionError(f"{m.name}: own columns repeat common ones")
        if m.at_rest is None:
            raise AssertionError(f"{m.name}: no force at rest (at_rest: stored_energy)")
        if m.hysteretic and m.lag is _no_lag:
            raise AssertionError(f"{m.name}: a hysteretic gear tracks its curves with a lag")


_check_registry()
