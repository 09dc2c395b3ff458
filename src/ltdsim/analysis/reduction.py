"""Model reduction: fit the simplified coupler to a detailed gear (paper §3, Table 1, Fig. 3).

Both gears are driven through the same history, shaped like the study's 14.6 s chain of
sines (8 s at pi/2 rad/s, 4 s at pi, 2 s at 2 pi, 0.4 s at 10 pi, 0.2 s at 20 pi). The
simplified coupler's ``[b, k1, k2, k3, v_c]`` minimise the sum of squared differences
between the two gear forces, found by ``scipy.optimize.differential_evolution`` (a
global evolutionary optimiser, like the study's genetic algorithm) with workers in
parallel and a final gradient polish, on a log scale.

Two rigs:

* ``"deflection"`` (default): the gear deflection follows the chain of sines, with
  amplitudes set as fractions of the gear's travel (the 1e6 N segments at half the
  travel, the 1e7 N segments at 85 %). Both gears see exactly the same motion.
* ``"force"``: a mass on the gear pushed by the study's forces (1e6 N and 1e7 N). With
  those amplitudes any real gear closes solid (about 3 MN for the high set, 0.3 MN for
  the low set) and the rig resonates near 1 Hz, so the fit is dominated by solid impacts
  that a five-parameter law cannot follow; it is offered for completeness.
"""

from __future__ import annotations

import os
import time as _time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import differential_evolution, minimize

from ltdsim.analysis.gears import STUDY_SINES, sine_chain
from ltdsim.engine.rig import RIG_FORCE, _lowered_gear, integrate_rig
from ltdsim.analysis.identify import fit_percent
from ltdsim.physics.gears.couplers import coupler_simplified
from ltdsim.scenario import CouplerParams, SimplifiedCoupler

#: fitted parameter names (keys of a simplified coupler) and default search bounds
PARAMETERS = ("damping", "k1", "k2", "k3", "v_c")
DEFAULT_BOUNDS = {
    "damping": (1e2, 1e5),  # N s/m
    "k1": (1e5, 1e8),  # N/m
    "k2": (1e3, 5e7),  # N/m
    "k3": (1e5, 1e8),  # N/m
    "v_c": (1e-2, 5.0),  # m (fade with the deflection) or m/s (with the rate)
}
#: default rig mass (force rig): the nine wagons behind the study's first coupler, kg
DEFAULT_MASS = 8.1e5
#: deflection rig: amplitude as a share of the gear travel for each force level
TRAVEL_SHARE = {1e6: 0.5, 1e7: 0.85}


def deflection_chain(travel: float, slack: float, segments=STUDY_SINES, dt: float = 5e-4):
    """The chain of sines as a deflection history ``(t, d)`` (s, m): amplitude
    ``share x travel`` beyond the slack (see :data:`TRAVEL_SHARE`), passing smoothly
    through the slack at every zero crossing."""
    scaled = [((TRAVEL_SHARE.get(a, 0.5) * travel + 0.5 * slack), w, dur)
              for a, w, dur in segments]
    return sine_chain(scaled, dt=dt)


class DeflectionObjective:
    """Sum of squared force errors of a simplified coupler along a deflection record.

    The simplified coupler has no internal state, so its force is a direct function of
    the recorded deflection and rate: one vectorised evaluation per candidate.
    Picklable for worker processes.
    """

    def __init__(self, slack, d, dd, target, fade: str = "deflection"):
        self.slack = float(slack)
        self.by_rate = fade == "rate"
        self.d = np.asarray(d, dtype=float)
        self.dd = np.asarray(dd, dtype=float)
        self.target = np.asarray(target, dtype=float)

    def force(self, values) -> np.ndarray:
        b, k1, k2, k3, v_c = values
        return coupler_simplified(self.d, self.dd, self.slack, 0.0, b, k1, k2, k3, v_c,
                                  self.by_rate, np.inf, 0.0)

    def __call__(self, log_values) -> float:
        err = self.force(10.0 ** np.asarray(log_values)) - self.target
        value = float(err @ err)
        return value if np.isfinite(value) else 1e300


class RigObjective:
    """Sum of squared force errors of a simplified coupler against a target record.

    Picklable, so that differential_evolution can send it to worker processes.
    """

    def __init__(self, slack, t, force_in, target, mass, dt, method="ode3",
                 fade: str = "deflection"):
        self.slack = slack
        self.fade = fade
        self.t = np.ascontiguousarray(t, dtype=float)
        self.force_in = np.ascontiguousarray(force_in, dtype=float)
        self.target = np.asarray(target, dtype=float)
        self.mass = float(mass)
        self.dt = dt
        self.method = method

    def force(self, values) -> np.ndarray:
        """Gear force history (N) of the simplified coupler with ``values`` (SI)."""
        # (a candidate of the search, not user input: built without validation, so that
        # search bounds wider than the scenario's ranges still evaluate)
        c = SimplifiedCoupler.model_construct(
            slack=self.slack, fade=self.fade,
            **dict(zip(PARAMETERS, (float(v) for v in values))))
        model, cpl, ctab = _lowered_gear(c)
        return integrate_rig(model, cpl, ctab, RIG_FORCE, self.t, self.force_in,
                             self.force_in, self.mass, self.t[-1] - self.t[0], self.dt,
                             self.method).force

    def __call__(self, log_values) -> float:
        f = self.force(10.0 ** np.asarray(log_values))
        err = f - self.target
        value = float(err @ err)
        return value if np.isfinite(value) else 1e300


@dataclass
class Reduction:
    """Result of :func:`reduce_gear`."""

    parameters: dict  # fitted simplified-coupler keys, SI
    fit_percent: float  # 100 (1 - ||f - f_target|| / ||f_target - mean||)
    cost: float  # sum of squared force errors, N^2
    evaluations: int
    generations: int
    message: str
    time: np.ndarray = field(repr=False)
    force_in: np.ndarray = field(repr=False)
    target_force: np.ndarray = field(repr=False)
    target_deflection: np.ndarray = field(repr=False)
    fitted_force: np.ndarray = field(repr=False)
    #: what the fitted k2 fades with ("deflection" or "rate", the simplified coupler's
    #: key ``fade``)
    fade: str = "deflection"

    def coupler(self, slack: float) -> CouplerParams:
        """The fitted simplified coupler as scenario parameters."""
        return CouplerParams(model="simplified", slack=slack, fade=self.fade,
                             **self.parameters)

    def toml(self, slack: float) -> str:
        """The fitted coupler as a ``[couplers.default]`` TOML table."""
        lines = ["[couplers.default]", 'model = "simplified"', f"slack = {slack!r}",
                 f'fade = "{self.fade}"']
        units = {"damping": "N s/m", "k1": "N/m", "k2": "N/m", "k3": "N/m",
                 "v_c": "m/s" if self.fade == "rate" else "m"}
        lines += [f"{k} = {v:.6g}   # {units[k]}" for k, v in self.parameters.items()]
        lines.append(f"# fitted by ltdsim reduce: fit {self.fit_percent:.2f} %")
        return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Search:
    """Settings of the differential evolution (``scipy.optimize.differential_evolution``):
    relative tolerance ``tol`` (-), at most ``maxiter`` generations, ``popsize`` times as
    many candidates as parameters, random ``seed``; then the best candidate is polished
    by L-BFGS-B (finite-difference gradients) in at most ``polish_runs`` rig runs (0: no
    polish). The study's gears polish in under 100 runs."""

    tol: float = 1e-4
    maxiter: int = 1000
    popsize: int = 15
    seed: int = 0
    polish_runs: int = 2000


@dataclass(frozen=True)
class SearchEstimate:
    """How long :func:`reduce_gear`'s search can take, from one generation's worth of
    rig runs timed through the same pool as the search (so that the cost of sending
    candidates to the processes counts): at most ``(maxiter + 1) popsize n`` candidates
    (``n`` parameters; the initial population and one per member and generation) and the
    polish's ``polish_runs`` (:class:`Search`). The search usually stops much earlier, once the
    population's spread falls under the tolerance."""

    seconds_per_run: float  # s of wall time per rig run, processes and transfers included
    max_runs: int  # rig runs at most, -
    workers: int  # processes evaluating candidates in parallel, -

    @property
    def upper_seconds(self) -> float:
        """Wall time of the search if it runs all its generations, s."""
        return self.max_runs * self.seconds_per_run

    def line(self) -> str:
        """The estimate in words, for the user before the search starts."""
        from ltdsim.engine.run import duration

        return (f"the search takes up to about {duration(self.upper_seconds)} "
                f"({self.max_runs} rig runs, {self.seconds_per_run:.2g} s each on {self.workers} "
                f"process{'es' if self.workers > 1 else ''}); it stops earlier once converged")


def _workers_used(workers: int) -> int:
    """Processes that evaluate candidates at once for the option ``workers`` (-1: every
    core), never more than the cores this process may use."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # (not on Linux)
        cores = os.cpu_count() or 1
    return cores if workers == -1 else max(1, min(workers, cores))


def _seconds_per_run(objective, batch, mapper) -> float:
    """Wall time per run of ``objective`` over ``batch`` through ``mapper``, s."""
    start = _time.perf_counter()
    list(mapper(objective, batch))
    return (_time.perf_counter() - start) / len(batch)


def reduce_gear(target: CouplerParams, *, rig: str = "deflection", segments=None,
                mass: float = DEFAULT_MASS, dt: float = 5e-4, bounds: dict | None = None,
                workers: int = 1, search: Search = Search(), progress=None,
                fade: str = "deflection", before_search=None) -> Reduction:
    """Fit a simplified coupler to ``target``.

    Parameters
    ----------
    target : CouplerParams
        The detailed gear (e.g. ``CouplerParams(preset="friction-wedge-high")``); its
        slack is kept.
    rig : {"deflection", "force"}
        How both gears are driven (module docstring).
    segments : sequence of (amplitude N, angular frequency rad/s, duration s), optional
        The excitation; default :data:`STUDY_SINES`.
    mass : float
        Rig mass of the force rig, kg.
    dt : float
        Sample and integration step, s.
    bounds : dict, optional
        ``{name: (low, high)}`` search bounds overriding :data:`DEFAULT_BOUNDS`.
    workers : int
        Parallel processes for the population (-1: all cores), used only where they are
        faster than this process alone (one generation's worth of rig runs is timed both
        ways: a cheap rig run costs less than sending it to a process). The search is
        the same whatever the processes (candidates of a generation are all evaluated
        before the population is updated), so the result does not depend on them. They
        are spawned and end with this process even when it is killed; a script that asks
        for more than one runs its work under ``if __name__ == "__main__":``.
    search : Search
        The optimiser's tolerance, generations, population and seed.
    progress : callable, optional
        Called as ``progress(generation, maxiter, best_cost)`` after each generation.
    fade : {"deflection", "rate"}
        What the fitted coupler's k2 fades with (the simplified coupler's key ``fade``).
    before_search : callable, optional
        Called as ``before_search(estimate)`` with the :class:`SearchEstimate` once the
        target's record is made and before the search starts (it may raise to refuse).
    """
    from ltdsim.analysis.gears import drive_deflection, drive_force

    segments = STUDY_SINES if segments is None else segments
    if rig == "deflection":
        travel = target.travel or 0.08
        t, d = deflection_chain(travel, target.slack, segments, dt=dt)
        ref = drive_deflection(target, t, d, dt=dt)
        objective = DeflectionObjective(target.slack, ref.deflection.values, ref.rate.values,
                                        ref.force.values, fade)
    elif rig == "force":
        t, f_in = sine_chain(segments, dt=dt)
        ref = drive_force(target, t, f_in, mass=mass, dt=dt)
        objective = RigObjective(target.slack, t, f_in, ref.force.values, mass, dt,
                                 fade=fade)
    else:
        raise ValueError(f"rig must be 'deflection' or 'force', got {rig!r}")
    b = {**DEFAULT_BOUNDS, **(bounds or {})}
    log_bounds = [(np.log10(b[k][0]), np.log10(b[k][1])) for k in PARAMETERS]
    generation = [0]

    def callback(intermediate_result):
        generation[0] += 1
        if progress is not None:
            progress(generation[0], search.maxiter, float(intermediate_result.fun))

    n = len(PARAMETERS)
    runs = (search.maxiter + 1) * search.popsize * n + search.polish_runs
    centre = np.array([(lo + hi) / 2.0 for lo, hi in log_bounds])
    batch = [centre] * (search.popsize * n)
    objective(centre)  # (compiles the rig on a first use)
    alone = _seconds_per_run(objective, batch, map)

    def optimise(mapper, per_run, used):
        if before_search is not None:
            before_search(SearchEstimate(seconds_per_run=per_run, max_runs=runs, workers=used))
        return differential_evolution(objective, log_bounds, tol=search.tol,
                                      maxiter=search.maxiter, popsize=search.popsize,
                                      seed=search.seed, workers=mapper, updating="deferred",
                                      polish=False, callback=callback)

    used = _workers_used(workers)
    res = None
    if used > 1:  # scipy's own pool would outlive this process if it were killed
        from ltdsim._workers import process_pool

        with process_pool(used) as pool:
            list(pool.map(objective, [centre] * used))  # (the processes start, compile)
            pooled = _seconds_per_run(objective, batch, pool.map)
            if pooled < alone:
                res = optimise(pool.map, pooled, used)
    if res is None:
        res = optimise(map, alone, 1)
    evaluations = int(res.nfev)
    if search.polish_runs > 0:  # (as scipy's own polish, with a bound on its runs)
        polished = minimize(objective, res.x, method="L-BFGS-B", bounds=log_bounds,
                            options={"maxfun": search.polish_runs})
        evaluations += int(polished.nfev)
        if polished.fun < res.fun:
            res.x, res.fun = polished.x, polished.fun
    values = 10.0 ** res.x
    fitted = objective.force(values)
    return Reduction(
        parameters=dict(zip(PARAMETERS, (float(v) for v in values))),
        fit_percent=fit_percent(ref.force.values, fitted), cost=float(res.fun),
        evaluations=evaluations, generations=generation[0], message=str(res.message),
        time=ref.time.values, force_in=ref.deflection.values if rig == "deflection" else f_in,
        target_force=ref.force.values, target_deflection=ref.deflection.values,
        fitted_force=fitted, fade=fade)
