"""Largest stable step of the explicit fixed-step methods for a given train.

An explicit Runge-Kutta method applied to ``y' = lambda y`` multiplies the state by its
stability polynomial ``R(z)``, ``z = h lambda``, every step (h: step, s). A mode is
integrated without growing while ``|R(h lambda)| <= 1``. ``R`` follows from the Butcher
tableau alone: ``R(z) = 1 + sum_k z^k b^T A^(k-1) 1`` (:func:`stability_polynomial`).

The train, linearised with every coupling at its stiffest, is a chain of masses ``m_i``
(kg) joined by springs ``k_j`` (N/m) and dampers ``c_j`` (N s/m). Its highest natural
frequency ``omega`` (rad/s) is the largest eigenvalue of ``M^-1/2 K M^-1/2`` (a
tridiagonal matrix; :func:`highest_mode`). Its damping ratio is at least
``zeta = alpha omega / 2`` with ``alpha = min_j c_j / k_j`` (s): the Rayleigh quotient of
the damping matrix over the stiffness matrix is a weighted mean of the couplings'
``c_j / k_j``. The mode's eigenvalue ``lambda = omega (-zeta +- i sqrt(1 - zeta^2))`` then
gives the largest stable step ``h = r / omega``, ``r`` the distance from the origin to the
edge of the stability region along that ray (:func:`ray_radius`).

Undamped, the ray is the imaginary axis: ``r = sqrt(3)`` for ode3, ``2 sqrt(2)`` for rk4,
and 0 for euler and heun, whose stability regions touch the imaginary axis only at the
origin: they let every undamped oscillation grow, at any step. With viscous damping
euler is stable for ``h < alpha`` (``|1 + z|^2 = 1 - 2 zeta omega h + (omega h)^2``).

First-order lags (the hysteretic gears' internal-force tracking, the brake cylinders,
the traction lag) are real eigenvalues ``-1/tau``; they are stable for
``h <= r_real tau`` with ``r_real`` = 2 (euler, heun), 2.51 (ode3), 2.79 (rk4).

The fluid air brake adds the brake pipe's waves and the valves' fills. The pipe's
fastest rate (:func:`ltdsim.physics.air.brakepipe.pipe_max_rate`, 1/s) bounds its
eigenvalues, which lie near the imaginary axis (sound waves, lightly damped by wall
friction); it is taken as an undamped oscillation, evaluated with the flow of an
emergency vent (Mach 0.6) in every face, so ``h <= r_imag / rate``: euler and heun have no
stable step for it. Each valve's fastest rate (``valve_max_rate``, 1/s) is a first-order
lag of ``tau = 1 / rate``.

The coupling at its stiffest (N/m): linear ``stiffness``; simplified ``max(k1, k2 + k3)``;
friction_wedge and table ``k_locked`` plus the steepest slope of their loading and
unloading curves (a locked gear crosses the band at ``k_locked`` relative to it); and, where
the gear has a ``travel``, ``solid_stiffness`` on top (the closed gear); a coupling of
two gears in series (``gears = 2``) has half one gear's. This bounds the frequency from
above: a real run meets the stiffest state only now and then.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigvalsh_tridiagonal

from ltdsim.engine.integrators import TABLEAUX
from ltdsim.engine.layout import A_COND, A_THERMAL

#: a step above this share of the largest stable step is warned about
WARN_SHARE = 0.8


def stability_polynomial(method: str) -> np.ndarray:
    """Coefficients ``c_0 .. c_s`` of ``R(z) = sum c_k z^k`` of fixed-step ``method``."""
    tab = TABLEAUX[method]
    coef = [1.0]
    v = np.ones(tab.stages)
    for _ in range(tab.stages):
        coef.append(float(tab.b @ v))
        v = tab.A @ v
    return np.array(coef)


@functools.lru_cache(maxsize=256)
def ray_radius(method: str, angle: float) -> float:
    """Distance from the origin to the edge of ``method``'s stability region along the
    ray ``z = r exp(i angle)`` (angle in rad: pi/2 the imaginary axis, pi the negative
    real axis); 0 when ``|R|`` exceeds 1 right from the origin; inf when it never does."""
    d = complex(math.cos(angle), math.sin(angle))
    c = stability_polynomial(method)
    a = c * d ** np.arange(len(c))  # R(r d) = sum a_k r^k
    p = np.convolve(a, np.conj(a)).real  # |R(r d)|^2 as a polynomial in r (low first)
    p[0] -= 1.0
    q = p[1:]  # (|R|^2 - 1) / r
    q[np.abs(q) < 1e-14] = 0.0
    nz = np.flatnonzero(q)
    if nz.size == 0:
        return math.inf
    if q[nz[0]] > 0.0:
        return 0.0  # grows for every small step
    roots = np.roots(q[::-1])
    real = sorted(r.real for r in roots if r.real > 0.0 and abs(r.imag) <= 1e-9 * abs(r))
    poly = np.polynomial.Polynomial(q)
    for r in real:
        if poly(r * (1 + 1e-7)) > 0.0:
            return float(r)
    return math.inf


def imaginary_radius(method: str) -> float:
    """Stable interval ``[0, r]`` of ``omega h`` for an undamped oscillation."""
    return ray_radius(method, math.pi / 2)


def real_radius(method: str) -> float:
    """Stable interval ``[0, r]`` of ``h / tau`` for a first-order lag ``tau``."""
    return ray_radius(method, math.pi)


def mode_step_limit(method: str, omega: float, zeta: float) -> float:
    """Largest stable step (s) for a mode of natural frequency ``omega`` (rad/s) and
    damping ratio ``zeta`` (-)."""
    if omega <= 0.0:
        return math.inf
    if zeta < 1.0:
        s = math.sqrt(1.0 - zeta * zeta)
        return ray_radius(method, math.atan2(s, -zeta)) / omega
    fast = omega * (zeta + math.sqrt(zeta * zeta - 1.0))  # the faster real root, 1/s
    return real_radius(method) / fast


# ----------------------------------------------------------------- the train's modes
def stiffest(c) -> float:
    """Tangent stiffness of coupling ``c`` (a validated coupler of any model) at its
    stiffest, N/m, its gears in series (see the module text; each model's entry in
    :mod:`ltdsim.engine.couplers` knows its own)."""
    from ltdsim.engine.couplers import stiffest as coupling_stiffest

    return coupling_stiffest(c)


def highest_mode(masses, stiffness, damping) -> tuple[float, float]:
    """``(omega rad/s, zeta -)``: the highest natural frequency of a free chain of
    ``masses`` (kg) joined by springs ``stiffness`` (N/m, one per coupling) and a lower
    bound of its damping ratio from the dampers ``damping`` (N s/m)."""
    m = np.asarray(masses, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    if k.size == 0:
        return 0.0, 0.0
    diag = np.zeros(m.size)
    diag[:-1] += k / m[:-1]
    diag[1:] += k / m[1:]
    off = -k / np.sqrt(m[:-1] * m[1:])
    top = eigvalsh_tridiagonal(diag, off, select="i", select_range=(m.size - 1, m.size - 1))
    omega = math.sqrt(max(float(top[0]), 0.0))
    alpha = float(np.min(np.asarray(damping, dtype=float) / k))
    return omega, 0.5 * alpha * omega


@dataclass(frozen=True)
class StepLimit:
    """The largest stable step of a scenario's fixed-step method and what sets it."""

    method: str
    dt: float  #: the scenario's step, s
    limit: float  #: the largest stable step, s
    omega: float  #: highest natural frequency of the stiffened train, rad/s
    zeta: float  #: its damping ratio (lower bound), -
    k_max: float  #: stiffest coupling, N/m
    lag: tuple[str, float] | None  #: the fastest first-order lag (its key, tau s), if any
    others: dict  #: the largest stable step of every fixed-step method, s
    pipe: float = 0.0  #: fastest rate of the fluid brake's pipe, 1/s (0: lumped brake)
    #: the dynamic brake's fade band near rest as a lag (its key, tau s), met only in a
    #: stop by the dynamic brake: it warns, it does not refuse (:func:`warning`)
    standstill: tuple[str, float] | None = None

    @property
    def standstill_limit(self) -> float:
        """The largest step at which a stop by the dynamic brake settles without
        chattering in its fade band, s (inf without one)."""
        if self.standstill is None:
            return math.inf
        return real_radius(self.method) * self.standstill[1]

    @property
    def share(self) -> float:
        """The step as a share of the largest stable step (above 1: unstable)."""
        return self.dt / self.limit if self.limit > 0.0 else math.inf

    def reason(self) -> str:
        """What sets the limit, in words with units."""
        osc = (f"the train's highest natural frequency, {self.omega / (2 * math.pi):.3g} Hz "
               f"(every coupling at its stiffest, up to {self.k_max:.3g} N/m; damping ratio "
               f"{self.zeta:.2g})")
        mode = mode_step_limit(self.method, self.omega, self.zeta)
        pipe = imaginary_radius(self.method) / self.pipe if self.pipe > 0.0 else math.inf
        if self.lag is not None:
            what, tau = self.lag
            lag_limit = real_radius(self.method) * tau
            if lag_limit <= mode and lag_limit <= pipe:
                return f"the first-order lag {what} = {tau:.3g} s"
        if pipe < mode:
            return (f"the brake pipe's fastest wave, {self.pipe:.3g} 1/s (its cells, "
                    "brake.fluid.cells_per_vehicle, with an emergency's flow)")
        return osc

    def alternatives(self) -> str:
        better = [f"{m} (up to {h:.3g} s)" for m, h in self.others.items()
                  if m != self.method and h > self.dt]
        return ", ".join(better) + (" or " if better else "") + "the adaptive bs23"


def step_limit(scenario, couplers=None, method: str | None = None,
               fluid: bool = True) -> StepLimit | None:
    """The largest stable step of ``scenario``'s fixed-step method (None for the adaptive
    bs23, whose error control keeps its steps stable), or of ``method`` if given (any
    method, also for a bs23 scenario). ``couplers``: the merged parameters of every
    coupler, if at hand (else ``scenario.coupler(j)``). ``fluid = False`` leaves the fluid
    brake's pipe and valves out (bs23 steps them apart, :func:`expected_steps`)."""
    from ltdsim.engine.couplers import fastest_lag

    sv = scenario.solver
    if sv.adaptive and method is None:
        return None
    method = method or sv.method
    masses = [v.mass for v in scenario.vehicles]
    if couplers is None:
        couplers = [scenario.coupler(j) for j in range(scenario.n_couplers)]
    ks, cs, lags = [], [], []
    standstill = None
    for j, c in enumerate(couplers):
        ks.append(stiffest(c))
        cs.append(c.damping)
        lag = fastest_lag(c)  # (models with internal states)
        if lag is not None:
            lags.append((f"{lag[0]} of coupler {j + 1}", lag[1]))
    pipe = 0.0
    if any(v.brake is not None for v in scenario.vehicles):
        b = scenario.brake
        if b.model == "fluid":
            if fluid:
                pipe, valves = fluid_rates(scenario)
                lags += valves
        else:
            lags.append(("brake.apply_time_constant", b.apply_time_constant))
            lags.append(("brake.release_time_constant", b.release_time_constant))
    tr = scenario.traction
    for k, loco in enumerate(scenario.consists()):
        own = scenario.locomotives and loco.time_constant is not None
        tau = loco.time_constant if own else tr.time_constant
        if tau > 0.0:
            lags.append((f"locomotives.{k}.time_constant" if own else "traction.time_constant",
                         tau))
        # a dynamic brake fades linearly to 0 within its fade speed of rest: there its
        # force is a damper of (its braking force / fade) on the consist's mass, a lag
        # of mass x fade / force (s), met only once the brake has stopped the train (a
        # step above it makes the stopped train chatter within the band, bounded by the
        # demand: warned, not refused)
        f_max = loco.max_force if scenario.locomotives and loco.max_force is not None \
            else tr.max_force
        mass = sum(scenario.vehicles[i].mass for i in loco.vehicles)
        braking = _braking_force(scenario, loco, f_max)
        if mass > 0.0 and braking > 0.0:
            key = ("traction.dynamic_brake_fade" if tr.dynamic_brake_fade > 0.0
                   else "traction.standstill_speed")
            band = (f"{key} (the dynamic brake near rest, consist {k + 1})",
                    mass * tr.brake_fade / braking)
            if standstill is None or band[1] < standstill[1]:
                standstill = band
    lags += drive_lags(scenario)
    omega, zeta = highest_mode(masses, ks, cs)
    lag = min(lags, key=lambda t: t[1]) if lags else None

    def limit(method):
        h = mode_step_limit(method, omega, zeta)
        if lag is not None:
            h = min(h, real_radius(method) * lag[1])
        if pipe > 0.0:
            h = min(h, imaginary_radius(method) / pipe)
        return h

    others = {m: limit(m) for m in TABLEAUX}
    return StepLimit(method, sv.dt, others[method], omega, zeta,
                     max(ks) if ks else 0.0, lag, others, pipe, standstill)


#: bs23's steps (accepted and rejected) over ``t_end`` divided by the stiffest-rate step
#: of :func:`expected_steps`, as measured on the shipped bs23 scenarios (200 s of each:
#: 1.0 to 2.0; docs/solver.md "Estimates"): the estimate's factor
ADAPTIVE_STEP_FACTOR = 2.0


@dataclass(frozen=True)
class StepCount:
    """How many steps a run takes: exactly for a fixed step, estimated for bs23."""

    steps: float  #: steps of the train's states (bs23: accepted and rejected), -
    h: float  #: the step that sets the count, s
    what: str  #: what sets that step, in words
    air_steps: float = 0.0  #: bs23 with the fluid brake: the pneumatic states' steps, -
    air_h: float = math.inf  #: the step that sets ``air_steps``, s
    air_what: str = ""


def expected_steps(scenario) -> StepCount:
    """The steps a run of ``scenario`` takes. Fixed step: ``solver.n_steps``. bs23: from
    the stiffest rate, ``ADAPTIVE_STEP_FACTOR x t_end / h`` with ``h`` the smaller of
    ``solver.max_step`` and the largest step the pair (ode3's stability region) keeps
    stable on the train linearised at its stiffest (:func:`step_limit` without the fluid
    brake); with the fluid brake also the pneumatic states' steps, from
    ``solver.air_max_step`` and the pipe's and valves' fastest rates (:func:`fluid_rates`).
    An error control that meets its tolerances with longer steps than the stiffest
    state allows takes fewer; the estimate is for planning, good to a factor of about 2."""
    sv = scenario.solver
    if not sv.adaptive:
        return StepCount(float(sv.n_steps), sv.dt, f"solver.dt = {sv.dt:g} s ({sv.method})")
    t_end = sv.n_steps * sv.dt
    lim = step_limit(scenario, method="ode3", fluid=False)
    if lim.limit < sv.max_step:
        h, what = lim.limit, f"the stiffest rate, {lim.reason()}"
    else:
        h, what = sv.max_step, f"solver.max_step = {sv.max_step:g} s"
    count = StepCount(ADAPTIVE_STEP_FACTOR * t_end / h, h, what)
    if scenario.brake.model != "fluid" or not any(v.brake is not None
                                                  for v in scenario.vehicles):
        return count
    pipe, valves = fluid_rates(scenario)
    air_h, air_what = sv.air_max_step, f"solver.air_max_step = {sv.air_max_step:g} s"
    r_pipe = imaginary_radius("ode3") / pipe if pipe > 0.0 else math.inf
    if r_pipe < air_h:
        air_h, air_what = r_pipe, f"the brake pipe's fastest wave, {pipe:.3g} 1/s"
    for name, tau in valves:
        if real_radius("ode3") * tau < air_h:
            air_h, air_what = real_radius("ode3") * tau, f"{name} = {tau:.3g} s"
    return dataclasses.replace(count, air_steps=ADAPTIVE_STEP_FACTOR * t_end / air_h,
                               air_h=air_h, air_what=air_what)


def drive_lags(scenario) -> list[tuple[str, float]]:
    """The fastest first-order lags of the induction drives, ``(what, tau s)``: for each
    consist on the induction drive its current loops' time constant
    ``1 / (2 pi current_bandwidth)`` and its stator's transient time constant
    ``sigma L_s / R_sigma`` (the plant pole the loops' PI cancels, which stays a mode of
    the state); empty without an induction drive."""
    from ltdsim.physics.drive import foc

    tr = scenario.traction
    ks = [k + 1 for k, loco in enumerate(scenario.consists())
          if (loco.drive or tr.drive) == "induction"]
    if not ks:
        return []
    loops, stator = foc.time_constants(foc.controller_row(tr.motor.motor()))
    which = f"consist {ks[0]}" if len(ks) == 1 else f"consists {', '.join(map(str, ks))}"
    return [(f"the induction drive's current loops ({which}), 1 / (2 pi "
             "traction.motor.current_bandwidth)", loops),
            (f"the induction drive's stator transient ({which}), sigma L_s / R_sigma "
             "of traction.motor", stator)]


def _braking_force(scenario, loco, f_max) -> float:
    """The largest braking force the driver can ask of consist ``loco`` near standstill
    (N, >= 0) with its force limit ``f_max`` (N): the speed controller's, down to
    ``max_decel`` x the train's mass, when its reference speed comes within the fade
    speed of rest (a run it never brings to a stop never meets the fade band); in
    force mode the most negative point of the profile, in notch mode its most negative
    notch (or the consist's own notch profile's) over 8 of f_max; all within f_max."""
    dr = scenario.driver
    own = getattr(loco, "notch_profile", None)
    if own:
        return f_max * max([-n for _, n in own] + [0.0]) / 8.0
    if dr.mode == "speed":
        if min(p[1] for p in dr.speed_profile) > scenario.traction.brake_fade:
            return 0.0
        mass = sum(v.mass for v in scenario.vehicles)
        return min(f_max, scenario.traction.max_decel * mass)
    if dr.mode == "notch":
        return f_max * max([-n for _, n in dr.notch_profile] + [0.0]) / 8.0
    return min(f_max, max([-f for _, f in dr.force_profile] + [0.0]))


#: Mach number of the flow in every pipe face at which :func:`fluid_rates` bounds the
#: pipe's rates (an emergency vent draws the pipe at Mach 0.3-0.6 near it)
EMERGENCY_MACH = 0.6


def fluid_rates(scenario) -> tuple[float, list[tuple[str, float]]]:
    """The fluid brake's fastest pipe rate (1/s; flow at :data:`EMERGENCY_MACH` in every
    face, at the regulated pressure) and its valves' fastest rates as lags
    ``(what, tau s)``, for the step check."""
    from ltdsim.engine.lowering import lower_fluid_parts
    from ltdsim.physics.air.brakepipe import pipe_max_rate
    from ltdsim.physics.air.brakevalves import valve_max_rate

    parts = lower_fluid_parts(scenario)
    a = scenario.brake.air
    fl = scenario.brake.fluid
    gas_row = parts["gas"]
    area = math.pi * fl.pipe_diameter ** 2 / 4.0
    dx = parts["geometry"].dx_cell
    rt = a.gas_constant * a.temperature
    p = np.full(dx.size, parts["p_abs"])
    rho = np.full(dx.size, parts["rho"])
    q = np.full(dx.size - 1, EMERGENCY_MACH * math.sqrt(a.gamma * rt) * area * parts["rho"])
    pipe = pipe_max_rate(p, q, rho, (area, dx, parts["geometry"].dx_face, parts["volume"],
                                     fl.pipe_diameter, fl.roughness, parts["viscosity"],
                                     gas_row[A_COND], parts["leak"]),
                         (a.gamma, a.gas_constant, a.temperature, 0.0, a.linear_ratio,
                          gas_row[A_THERMAL]))
    cell = float(area * dx.min())
    p_max = max(parts["p_abs"], parts["p_main"])
    gas = dict(gamma=a.gamma, r_gas=a.gas_constant, temperature=a.temperature,
               r_lin=a.linear_ratio)
    cv = valve_max_rate(parts["cv_row"], "control", cell, p_max, **gas)
    dv = valve_max_rate(parts["dv_row"], "driver", cell, p_max, **gas)
    return float(pipe), [("the control valves' fastest fill (brake.fluid.valve), 1 / rate",
                          1.0 / cv),
                         ("the driver's valve's fastest fill (brake.fluid.valve), 1 / rate",
                          1.0 / dv)]


def refusal(lim: StepLimit) -> str:
    """The one-line reason a step above the limit is refused."""
    if lim.limit == 0.0:
        head = (f"{lim.method} has no stable step for this train: it lets the undamped "
                f"oscillation at {lim.reason()} grow at any step")
    else:
        head = (f"{lim.dt:g} s is above the largest stable step of {lim.method} for this "
                f"train, {lim.limit:.3g} s, set by {lim.reason()}: at this step that mode "
                "grows from step to step")
    return (f"solver.dt: {head}, so the results drift or blow up. Set solver.dt to at most "
            f"{lim.limit:.3g} s or use {lim.alternatives()} (or solver.stability_check = "
            "false to run it anyway)")


def warning(lim: StepLimit | None) -> str | None:
    """A line for a step near (above ``WARN_SHARE`` of) the largest stable step, or above
    the step at which a stop by the dynamic brake settles (:attr:`StepLimit.standstill`)."""
    if lim is None or lim.share > 1.0:
        return None
    if lim.share > WARN_SHARE:
        return (f"solver.dt = {lim.dt:g} s is {lim.share:.0%} of the largest stable step "
                f"of {lim.method} for this train ({lim.limit:.3g} s, set by "
                f"{lim.reason()}); a stiffer moment may grow: consider a smaller solver.dt")
    if lim.dt > lim.standstill_limit:
        what, tau = lim.standstill
        return (f"solver.dt = {lim.dt:g} s is above {lim.standstill_limit:.3g} s, the "
                f"largest step of {lim.method} at which a train the dynamic brake stops "
                f"comes to rest: the first-order lag {what} = {tau:.3g} s; a stopped train "
                "would chatter within the fade band. Consider a smaller solver.dt, a wider "
                "band, or bs23")
    return None


def check(scenario, source: str | None = None) -> StepLimit | None:
    """Refuse, before anything runs, a fixed step above the method's largest stable step
    for ``scenario``'s train (unless ``solver.stability_check = false``): raises
    :class:`~ltdsim.errors.ScenarioError` naming ``source`` (the file or ``--set`` that
    asked for the step; default the scenario's name), the key, the limit and what sets
    it (:func:`refusal`). Returns the limit (None under bs23)."""
    from ltdsim.errors import ScenarioError

    lim = step_limit(scenario)
    if lim is not None and scenario.solver.stability_check and lim.share > 1.0:
        raise ScenarioError(source or f"scenario {scenario.name!r}", [("", refusal(lim))])
    if scenario.solver.adaptive and scenario.solver.hold_speed is not None \
            and not _any_holdable(scenario):
        raise ScenarioError(source or f"scenario {scenario.name!r}", [(
            "solver.hold_speed", "no coupling of this train can be held at its slack edge, "
            "so the key would have no effect: it needs a friction_wedge, table or polymer "
            "gear with a preload, a slack and no edge_stiffness; leave it out")])
    return lim


def _any_holdable(scenario) -> bool:
    """Has ``scenario``'s train a coupling that ``solver.hold_speed`` may hold
    (:func:`ltdsim.engine.lowering.hold_force`)?"""
    from ltdsim.engine.couplers import lower_coupler
    from ltdsim.engine.lowering import hold_force

    n = sum(v.count for v in scenario.vehicles)
    seen = set()
    for i in range(n - 1):
        c = scenario.coupler(i)
        key = c.model_dump_json()
        if key in seen:
            continue
        seen.add(key)
        if hold_force(lower_coupler(c, [], sign0=0.0, state_offset=0)) > 0.0:
            return True
    return False

