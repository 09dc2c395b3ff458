"""Parameter sweeps: many scenario variants on local processes or a Dask cluster.

A sweep is a base scenario and a list of cases, each a set of dotted-key overrides:

* a scenario file: its named ``[cases.*]`` (the study's 16 L/H cases);
* a sweep file (TOML) naming a scenario and one of ``[grid]`` (full factorial),
  ``[list]`` (zipped lists) or ``[monte_carlo]`` (seeded samples), plus ``[overrides]``
  applied to every case (see docs/sweep.md).

Cases run through one code path on a ``concurrent.futures`` executor: a local process
pool by default, or ``distributed.Client(address).get_executor()`` for a Dask cluster.
Each finished case is written atomically (``cases/<id>.json``: status, error, summary
and phase norms; optionally ``cases/<id>.nc``) by the process that runs the sweep, so
workers need no shared disk. A case whose file exists with the same content
fingerprint is not run again: an interrupted sweep resumes with the same command.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import logging
import math
import os
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim.errors import LtdsimError, ScenarioError
from ltdsim.results.io import (atomic_path, file_problem, file_record, read_sealed, same_file,
                       sealed_json)
from ltdsim.scenario import Scenario, load_scenario, read_toml

SWEEP_KEYS = {"name", "scenario", "case", "overrides", "grid", "list", "monte_carlo"}
DISTRIBUTIONS = {"uniform": ("low", "high"), "normal": ("mean", "std"),
                 "lognormal": ("mean", "sigma")}
#: the most cases one sweep may hold (grid, list or Monte-Carlo samples); a larger grid
#: is refused with its count before any case is made
MAX_CASES = 100_000
#: ``progress(checked, total)`` while the cases of a large sweep are validated
Checked = Callable[[int, int], None]
#: built scenarios a sweep keeps at once (each case is rebuilt from its overrides when
#: it is needed again, so a large sweep's memory does not grow with its cases)
_KEEP_BUILT = 256


@dataclass
class Case:
    """One case of a sweep: an id and the dotted-key overrides that make it."""

    id: str
    overrides: dict


class LazyCases(Sequence):
    """A read-only sequence of ``n`` cases, case ``i`` made by ``make(i)`` when it is
    asked for: a grid of many cases takes no memory until its cases are used."""

    def __init__(self, n: int, make: Callable[[int], Case]):
        self._n = n
        self._make = make

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self._make(j) for j in range(*i.indices(self._n))]
        if i < 0:
            i += self._n
        if not 0 <= i < self._n:
            raise IndexError(i)
        return self._make(i)


def _grid_cases(keys: list[str], values: list[list], common: dict) -> LazyCases:
    """The full-factorial cases of ``keys`` x ``values`` in the order of
    ``itertools.product`` (the last key varies fastest), made one at a time."""
    sizes = [len(v) for v in values]

    def make(i: int) -> Case:
        picked = {}
        rest = i
        for key, vals, size in zip(reversed(keys), reversed(values), reversed(sizes)):
            rest, j = divmod(rest, size)
            picked[key] = vals[j]
        return Case(f"g{i:04d}", {**common, **{k: picked[k] for k in keys}})

    return LazyCases(math.prod(sizes), make)


@dataclass
class Sweep:
    """A base scenario, its cases, and where the sweep file came from.

    ``swept`` are the keys the cases vary (a grid's, a list's or the Monte-Carlo
    parameters, or every key a scenario file's named cases set; not the overrides common
    to every case), the summary's columns of the cases' values. ``largest`` is
    ``(bytes, case id)`` of the case whose run needs the most memory
    (:func:`ltdsim.engine.run.recording_bytes`), found when the cases are validated;
    ``slowest`` is ``(estimate, case id)`` of the case estimated to take longest and
    ``seconds`` the estimated wall time of every case together on one core
    (:func:`ltdsim.engine.run.estimate`)."""

    base: Scenario
    cases: Sequence[Case]
    source: str
    swept: tuple[str, ...] = ()
    largest: tuple[int, str] | None = None
    slowest: tuple[object, str] | None = None
    seconds: float = 0.0
    _built: OrderedDict = field(default_factory=OrderedDict, repr=False)

    def scenario(self, case: Case) -> Scenario:
        """The validated scenario of ``case`` (the last few built are kept)."""
        built = self._built.get(case.id)
        if built is None:
            built = self.base.with_overrides(case.overrides,
                                             source=f"{self.source} case {case.id}")
            self._built[case.id] = built
            while len(self._built) > _KEEP_BUILT:
                self._built.popitem(last=False)
        else:
            self._built.move_to_end(case.id)
        return built


def with_overrides(sweep: Sweep, overrides: dict, source: str = "--set",
                   progress: Checked | None = None) -> Sweep:
    """The sweep with dotted-key ``overrides`` applied to every case, after the case's own
    (so they win where both set a key). A bad override is reported once, as ``source``."""
    if not overrides:
        return sweep
    sweep.base.with_overrides(overrides, source=source)  # names a bad key once
    before = sweep.cases
    cases = LazyCases(len(before), lambda i: Case(before[i].id,
                                                  {**before[i].overrides, **overrides}))
    return _validated(Sweep(sweep.base, cases, sweep.source, sweep.swept), progress)


def fingerprint(scenario: Scenario, extras=()) -> str:
    """Content hash of a scenario, the analyses asked for and the code that computes
    them (what a finished case record was computed from)."""
    from ltdsim._provenance import code_hash

    text = json.dumps([scenario.to_dict(), sorted(extras), code_hash()], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# --------------------------------------------------------------------- sweep files
def load_sweep(path: str | Path, progress: Checked | None = None) -> Sweep:
    """Read a scenario file (its named cases) or a sweep file; validate every case.

    A grid is expanded lazily (its cases are made when used) and refused beyond
    :data:`MAX_CASES` cases before any is made. ``progress(checked, total)`` is called
    while the cases of a large sweep (1000 or more) are validated.

    Raises ScenarioError naming the file, key and problem.
    """
    path = Path(path)
    source = str(path)
    data = read_toml(path, "scenario or sweep file")
    if "scenario" not in data:
        base = load_scenario(path)
        if not base.cases:
            raise ScenarioError(source, [("cases", "the scenario has no [cases.*] to sweep; "
                                                   "give a sweep file instead")])
        cases = [Case(name, dict(ov)) for name, ov in base.cases.items()]
        swept = tuple(dict.fromkeys(k for c in cases for k in c.overrides))
        return _validated(Sweep(base, cases, source, swept), progress)

    if "makeups" in data:
        raise ScenarioError(source, [("", f"a make-up study file (its makeups key), not a "
                                          f"sweep: run it with `ltdsim makeup {path}`")])
    unknown = sorted(set(data) - SWEEP_KEYS)
    if unknown:
        raise ScenarioError(source, [(k, f"unknown key; allowed: {', '.join(sorted(SWEEP_KEYS))}")
                                     for k in unknown])
    kinds = [k for k in ("grid", "list", "monte_carlo") if k in data]
    if len(kinds) != 1:
        raise ScenarioError(source, [("", "give exactly one of [grid], [list] or "
                                          "[monte_carlo] (found "
                                          f"{', '.join(f'[{k}]' for k in kinds) or 'none'})")])
    kind = kinds[0]
    for key in ("overrides", kind):
        if key in data and not isinstance(data[key], dict):
            raise ScenarioError(source, [(key, f"expected a table [{key}], got "
                                               f"{type(data[key]).__name__}")])
    for key in ("scenario", "case", "name"):
        if key in data and not isinstance(data[key], str):
            raise ScenarioError(source, [(key, f"expected a string, got "
                                               f"{type(data[key]).__name__}")])
    target = path.parent / data["scenario"]
    if same_file(target, path):
        raise ScenarioError(source, [("scenario", "names this sweep file; give the scenario "
                                                  "file the cases start from")])
    base = load_scenario(target, case=data.get("case"))
    common = _dotted(data.get("overrides", {}))
    if kind == "grid":
        grid = _dotted(data["grid"])
        if not grid:
            raise ScenarioError(source, [("grid", "no keys to vary; give each key a list of "
                                                  "values")])
        keys = list(grid)
        values = [_values(source, f"grid.{k}", grid[k]) for k in keys]
        count = math.prod(len(v) for v in values)
        if count > MAX_CASES:
            raise ScenarioError(source, [("grid", f"{count:,} cases "
                                                  f"({' x '.join(str(len(v)) for v in values)}"
                                                  f" values) is more than {MAX_CASES:,}, the "
                                                  "most one sweep holds; give fewer values, "
                                                  "split the grid into several sweeps or "
                                                  "sample it with [monte_carlo]")])
        cases = _grid_cases(keys, values, common)
    elif kind == "list":
        table = _dotted(data["list"])
        if not table:
            raise ScenarioError(source, [("list", "no keys; give each key a list of values")])
        keys = list(table)
        values = [_values(source, f"list.{k}", table[k]) for k in keys]
        lengths = {len(v) for v in values}
        if len(lengths) != 1:
            raise ScenarioError(source, [("list", f"all lists must have one length, got "
                                                  f"{sorted(lengths)}")])
        if len(values[0]) > MAX_CASES:
            raise ScenarioError(source, [("list", f"{len(values[0]):,} cases is more than "
                                                  f"{MAX_CASES:,}, the most one sweep holds")])
        cases = [Case(f"l{i:04d}", {**common, **dict(zip(keys, c))})
                 for i, c in enumerate(zip(*values))]
    else:
        samples = _monte_carlo(source, data["monte_carlo"])
        keys = list(samples[0])
        cases = [Case(f"mc{i:04d}", {**common, **ov}) for i, ov in enumerate(samples)]
    return _validated(Sweep(base, cases, source, tuple(keys)), progress)


def _dotted(table: dict, prefix: str = "", leaf=lambda v: False) -> dict:
    """``{"solver": {"t_end": 10}}`` (TOML's unquoted ``solver.t_end = 10``) as
    ``{"solver.t_end": 10}``; quoted dotted keys stay as they are. A table for which
    ``leaf`` is true is kept whole (a Monte-Carlo distribution)."""
    out = {}
    for k, v in table.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and not leaf(v):
            out.update(_dotted(v, f"{key}.", leaf))
        else:
            out[key] = v
    return out


def _values(source, key, v):
    if not isinstance(v, list) or not v:
        raise ScenarioError(source, [(key, "expected a non-empty list of values, e.g. "
                                           "[1.0, 2.0]")])
    return v


def _monte_carlo(source, mc: dict) -> list[dict]:
    if not isinstance(mc, dict):
        raise ScenarioError(source, [("monte_carlo", "must be a table: [monte_carlo] with "
                                                     "samples, seed and parameters")])
    allowed = {"samples", "seed", "parameters"}
    bad = sorted(set(mc) - allowed)
    if bad:
        raise ScenarioError(source, [(f"monte_carlo.{k}", f"unknown key; allowed: "
                                                          f"{', '.join(sorted(allowed))}")
                                     for k in bad])
    n = mc.get("samples")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_CASES:
        raise ScenarioError(source, [("monte_carlo.samples", f"an integer from 1 to "
                                                             f"{MAX_CASES} (got {n!r})")])
    seed = mc.get("seed")
    if seed is None:
        raise ScenarioError(source, [("monte_carlo.seed", "required: samples must be "
                                                          "reproducible")])
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ScenarioError(source, [("monte_carlo.seed", f"a whole number, 0 or more "
                                                          f"(got {seed!r})")])
    params = mc.get("parameters", {})
    if not isinstance(params, dict):
        raise ScenarioError(source, [("monte_carlo.parameters", "expected a table "
                                                                "[monte_carlo.parameters]")])
    rng = np.random.default_rng(seed)
    columns = {}
    for key, spec in _dotted(params, leaf=lambda v: "dist" in v).items():
        where = f"monte_carlo.parameters.{key}"
        dist = spec.get("dist") if isinstance(spec, dict) else None
        if dist not in DISTRIBUTIONS:
            raise ScenarioError(source, [(f"{where}.dist",
                                          f"one of {', '.join(DISTRIBUTIONS)}")])
        args = DISTRIBUTIONS[dist]
        missing = [a for a in args if a not in spec]
        if missing:
            raise ScenarioError(source, [(where, f"{dist} needs {', '.join(args)}")])
        extra = sorted(set(spec) - {"dist", *args})
        if extra:
            raise ScenarioError(source, [(f"{where}.{extra[0]}", f"unknown key; {dist} takes "
                                                                 f"{', '.join(args)}")])
        for x in args:
            v = spec[x]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise ScenarioError(source, [(f"{where}.{x}", "must be a finite number (a TOML "
                                                              "integer or float: not in quotes, "
                                                              f"not true/false) (got {v!r})")])
        a, b = (float(spec[x]) for x in args)
        if dist == "uniform" and b < a:
            raise ScenarioError(source, [(f"{where}.high", f"must be at least low ({a:g}) "
                                                           f"(got {b:g})")])
        if dist in ("normal", "lognormal") and b < 0.0:
            raise ScenarioError(source, [(f"{where}.{args[1]}", f"must be 0 or more, a "
                                                                f"spread (got {b:g})")])
        columns[key] = getattr(rng, dist)(a, b, size=n)
    if not columns:
        raise ScenarioError(source, [("monte_carlo.parameters", "no parameters to sample")])
    return [{k: float(col[i]) for k, col in columns.items()} for i in range(n)]


def validated(sweep: Sweep, progress: Checked | None = None) -> Sweep:
    """``sweep`` (one made in code, not read from a file) with every case checked and
    the estimates filled in, as :func:`load_sweep` does for a file. Raises
    ScenarioError naming each bad case."""
    return _validated(sweep, progress)


def _validated(sweep: Sweep, progress: Checked | None = None) -> Sweep:
    """``sweep`` once every case's scenario is valid and its fixed step stable (else a
    ScenarioError naming each bad case, at most 20 of them;
    :func:`ltdsim.engine.preflight.check`), with its most memory-hungry case in
    ``largest``."""
    from ltdsim.engine.preflight import check
    from ltdsim.engine.run import estimate

    problems = []
    bad = 0
    largest = None
    slowest = None
    seconds = 0.0
    total = len(sweep.cases)
    report = progress if progress is not None and total >= 1000 else None
    for k, case in enumerate(sweep.cases):
        if report is not None and k % 500 == 0:
            report(k, total)
        try:
            sc = sweep.scenario(case)
            check(sc)
        except ScenarioError as exc:
            bad += 1
            if bad <= 20:
                problems += [(f"case {case.id}" + (f": {k}" if k else ""), m)
                             for k, m in exc.problems]
            continue
        est = estimate(sc)
        seconds += est.seconds
        if largest is None or est.bytes > largest[0]:
            largest = (est.bytes, case.id)
        if slowest is None or est.seconds > slowest[0].seconds:
            slowest = (est, case.id)
    if problems:
        if bad > 20:
            problems.append(("", f"... and {bad - 20:,} more cases with problems"))
        raise ScenarioError(sweep.source, problems)
    if report is not None:
        report(total, total)
    sweep.largest = largest
    sweep.slowest = slowest
    sweep.seconds = seconds
    return sweep


def check_sweep_time(sweep: Sweep, source: str, limit: float | None, anyway: str) -> None:
    """Refuse (ScenarioError), before any case runs, a sweep whose slowest case is
    estimated to take longer than ``limit`` seconds (None: no limit;
    :func:`ltdsim.engine.run.check_time`; ``anyway`` says how to raise it)."""
    from ltdsim.engine.run import duration

    if sweep.slowest is None or limit is None:
        return
    est, case_id = sweep.slowest
    if est.seconds > limit:
        raise ScenarioError(f"{source} case {case_id}", [(
            est.keys,
            f"the case would take about {duration(est.seconds)} ({est.line(False)}), "
            f"beyond the limit of {duration(limit)} for one case; raise its step, shorten "
            f"solver.t_end, or {anyway} to run it anyway")])


def check_sweep_memory(sweep: Sweep, source: str, workers: int | None = None) -> None:
    """Refuse (ScenarioError) a sweep whose largest case, run on every local worker at
    once (``workers``, default all cores), would take more than its share of the memory
    available (:func:`ltdsim.engine.run.check_memory`); checked before any case runs."""
    from ltdsim.engine.run import check_memory

    if sweep.largest is None:
        return
    need, case_id = sweep.largest
    parallel = max(1, min(workers if workers and workers > 0 else os.cpu_count() or 1,
                          len(sweep.cases)))
    case = next(c for c in sweep.cases if c.id == case_id)
    check_memory(sweep.scenario(case), source=f"{source} case {case_id}", parallel=parallel,
                 largest=need)


# ---------------------------------------------------------------------- one case
def case_summary(ds, scenario: Scenario | None = None) -> dict:
    """Per-case numbers: RMS speed error (m/s), max tension and compression per coupler
    (N; over the recorded samples, or over every step where a run did not record
    coupler_force), max |acceleration| per vehicle (m/s^2; NaN where not recorded), peak
    traction (N), wheel-slip samples. ``scenario`` made ``ds`` (by default read from
    the result)."""
    from ltdsim.results.summary import column_max, column_min, run_summary

    if "coupler_force" in ds:
        f = ds.coupler_force.values
        top, low = column_max(f), column_min(f)
    else:  # solver.record left it out: the peaks over every step
        top, low = ds.max_coupler_force.values, ds.min_coupler_force.values
    s = run_summary(ds, scenario)
    acc = (column_max(np.abs(ds.acceleration.values)) if "acceleration" in ds
           else np.full(ds.sizes["vehicle"], np.nan))
    return {
        "rms_speed_error_m_s": s["rms_speed_error_m_s"],
        "max_speed_error_m_s": s["max_speed_error_m_s"],
        "max_tension_N": np.maximum(top, 0.0).tolist(),
        "max_compression_N": np.maximum(-low, 0.0).tolist(),
        "max_abs_acceleration_m_s2": acc.tolist(),
        "max_traction_N": s["max_traction_N"],
        "samples_demand_over_adhesion": int(
            (np.abs(ds.traction_demand.values) > ds.adhesion_limit.values).sum()),
        "wall_time_s": s["wall_time_s"],
    }


def run_case(scenario_dict: dict, case_id: str, keep_result: bool = False,
             extras: tuple[str, ...] = ()) -> dict:
    """Simulate one case (in a worker) and return its record; failures are recorded,
    not raised. ``extras`` adds analyses of the time series to the record:
    ``"sysid"`` (identification locomotive force -> first wagon acceleration at 10 ms,
    with its step metrics) and ``"spectra"`` (phase spectra of the first and the last
    two couplers, each numbered as people count in ``coupler_number``: 1 = behind the
    lead), ``"peaks"`` (each coupler's largest tension and compression over every step,
    N, and when they occurred, s: the columns of
    :func:`ltdsim.results.summary.coupler_summary`, a list entry per coupler, coupler 1
    first) and ``"fatigue"`` (the couplers' fatigue damage the result carries, the rows
    of :func:`ltdsim.results.fatigue.stored_damage`, couplers numbered from 1; empty
    without fatigue curves)."""
    from ltdsim.analysis.phases import phase_norms
    from ltdsim.results.simulate import simulate

    record = {"id": case_id, "status": "ok", "error": None}
    try:
        sc = Scenario.from_dict(scenario_dict, f"case {case_id}")
        ds = simulate(sc, time_limit=None)  # (the sweep's limit was checked before it ran)
        record["summary"] = case_summary(ds, sc)
        try:
            norms = phase_norms(ds, sc)
            record["phase_norms"] = {k: v.values.tolist() for k, v in norms.data_vars.items()}
            record["phases"] = [str(p) for p in norms.phase.values]
        except ValueError:
            record["phase_norms"], record["phases"] = {}, []
        if "sysid" in extras:
            record["sysid"] = _sysid_record(ds, sc)
        if "peaks" in extras:
            from ltdsim.results.summary import coupler_summary

            if ds.sizes.get("coupler", 0):
                peaks = coupler_summary(ds)
                record["peaks"] = {k: peaks[k].tolist() for k in peaks.columns}
            else:
                record["peaks"] = {}
        if "fatigue" in extras:
            from ltdsim.results.fatigue import stored_damage

            table = stored_damage(ds)
            record["fatigue"] = ([] if table is None else json.loads(
                table.to_json(orient="records")))
        if "spectra" in extras:
            from ltdsim.analysis.spectra import phase_spectra

            nc = ds.sizes["coupler"]
            couplers = sorted({0, max(nc - 2, 0), nc - 1})
            record["spectra"] = phase_spectra(ds, sc, couplers).drop(
                columns="coupler").to_dict(orient="records")  # (the 0-based index)
        if keep_result:
            record["result"] = ds
    except LtdsimError as exc:
        record.update(status="failed", error=str(exc))
    except Exception as exc:  # noqa: BLE001 - a case must never stop the sweep
        record.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    return record


def _sysid_record(ds, scenario: Scenario) -> dict:
    """Identification of the first wagon's acceleration from the locomotive force per
    unit of train mass (so a rigid train's transfer function is 1, as the study's
    Appendix II models are at 0 Hz), at 10 ms, with its step and ramp metrics; and the
    same metrics of the physical step response (:func:`ltdsim.analysis.experiments.force_step`)
    and its physical quantities (:func:`ltdsim.analysis.experiments.step_physics`)."""
    from ltdsim.analysis.experiments import force_step_run, step_info, step_physics
    from ltdsim.analysis.identify import identify_result, prediction_fit
    from ltdsim.analysis.response import ramp_error, step_metrics

    mass = sum(v.mass for v in scenario.vehicles)
    ds = ds.assign(force_per_mass=ds.traction_force / mass)
    m = identify_result(ds, input_var="force_per_mass", resample_dt=0.01)
    u = ds.force_per_mass.values
    y = ds.acceleration.values[:, 1] if ds.sizes["vehicle"] > 1 else ds.acceleration.values[:, 0]
    info = step_metrics(m.tf())
    dc = float(np.sum(m.b) / np.sum(m.a))
    out = 1 if ds.sizes["vehicle"] > 1 else 0
    run, t0, step, total = force_step_run(scenario)
    tr = run.time.values
    before, after = (tr > 0.5 * t0) & (tr < t0), tr >= t0 + scenario.solver.dt
    acc = run.acceleration.values[:, out]
    t, r = tr[after] - t0, (acc[after] - acc[before].mean()) / (step / total)
    return {"sample_time_s": m.dt, "numerator": m.b.tolist(), "denominator": m.a.tolist(),
            "input": "locomotive force / train mass, m/s^2",
            "dc_gain": dc,
            "fpe": m.fpe, "mse": m.mse, "fit_percent": m.fit_percent,
            "prediction_fit_percent": m.prediction_fit_percent,
            "prediction_fit_percent_record_dt": prediction_fit(u, y),
            "evaluations": m.evaluations, "cost": m.cost, "norm_of_step": m.step_norm,
            "first_order_optimality": m.optimality,
            "step": {k: float(v) for k, v in info.items()},
            # the lag of the ramp response once the model is scaled to unit DC gain, s
            "ramp_error": ramp_error(m.tf() / dc) if dc else float("inf"),
            "force_step": step_info(t, r),
            # the same step in physical units (m/s^2, N, s), coupler 1's force with it
            "force_step_physics": (step_physics(run, t0, step, total,
                                                scenario.vehicles[0].mass, out)
                                   if run.sizes.get("coupler", 0) else {})}


# ------------------------------------------------------------------------ sweeps
def case_path(out: Path, case_id: str) -> Path:
    return Path(out) / "cases" / f"{case_id}.json"


def result_path(out: Path, case_id: str) -> Path:
    """Where ``--keep-results`` writes a case's time series."""
    return Path(out) / "cases" / f"{case_id}.nc"


def finished(out: Path, sweep: Sweep, retry_failed: bool = False, extras=(),
             keep_results: bool = False,
             notice: Callable[[str], None] | None = None) -> set[str]:
    """Ids of the cases already on disk with the same content fingerprint, their record
    intact (its content hash) and, with ``keep_results``, their time series too (size
    and content hash as written). A damaged record or time series is not finished:
    ``notice`` gets one line "recomputing case <id>: <why>" for each."""
    out = Path(out)
    done = set()
    for case in sweep.cases:
        p = case_path(out, case.id)
        try:
            rec = read_sealed(p)
        except FileNotFoundError:
            continue  # not run yet
        except ValueError as exc:
            _notice(notice, f"recomputing case {case.id}: {exc}")
            continue
        if rec.get("fingerprint") != fingerprint(sweep.scenario(case), extras):
            continue  # computed from another scenario or code: run again, as asked
        status = rec.get("status")
        if not (status == "ok" or (status == "failed" and not retry_failed)):
            continue
        if keep_results and status == "ok":
            kept = rec.get("result_file")
            why = (file_problem(kept, out) if kept is not None else
                   f"{result_path(out, case.id)} was not kept by the run that computed it "
                   "(--keep-results asks for it)")
            if why is not None:
                _notice(notice, f"recomputing case {case.id}: {why}")
                continue
        done.add(case.id)
    return done


def _remove_partial_files(out: Path, notice=None) -> None:
    """Remove the temporary files (``.<name>.<random>.part``, see
    :func:`ltdsim.results.io.atomic_path`) a killed run left in ``cases/``: never a finished
    file, only what was being written when the run stopped."""
    stale = [p for p in (Path(out) / "cases").glob(".*.part") if p.is_file()]
    for p in stale:
        p.unlink(missing_ok=True)
    if stale:
        _notice(notice, f"removed {len(stale)} unfinished temporary file(s) from a stopped "
                        f"run in {Path(out) / 'cases'}")


def _notice(notice, text: str) -> None:
    if notice is None:
        logging.getLogger("ltdsim").warning(text)
    else:
        notice(text)


def run_sweep(sweep: Sweep, out: str | Path, *, scheduler: str | None = None,
              workers: int | None = None, keep_results: bool = False,
              retry_failed: bool = False, extras: tuple[str, ...] = (),
              progress: Callable[[int, int, str], None] | None = None,
              on_compile: Callable[[float, bool], None] | None = None,
              notice: Callable[[str], None] | None = None) -> pd.DataFrame:
    """Run the unfinished cases of ``sweep`` into folder ``out``; return the summary.

    Parameters
    ----------
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://host:port``); local processes if None.
    workers : int, optional
        Local processes (default: all cores).
    keep_results : bool
        Also write every case's full time series as ``cases/<id>.nc``.
    retry_failed : bool
        Run again cases recorded as failed.
    extras : tuple of str
        Analyses added to each case record (see :func:`run_case`); part of the
        fingerprint, so asking for more reruns the cases.
    progress : callable, optional
        ``progress(done, total, case_id)`` after each finished case.
    on_compile : callable, optional
        ``on_compile(elapsed_s, done)`` while the kernels are compiled (first run only;
        see :func:`ltdsim.engine.warmup.warm_up`).
    notice : callable, optional
        ``notice(line)`` for each case found damaged on disk and run again
        ("recomputing case <id>: <why>"); logged as a warning if None.

    Returns
    -------
    pandas.DataFrame
        The sweep's summary, one row per case (:func:`summary_table`).

    Notes
    -----
    A case record (``cases/<id>.json``) holds the hash of its own content and, with
    ``keep_results``, the size and content hash of its ``cases/<id>.nc``: a record or a
    time series that is unreadable, truncated, emptied, deleted or altered is reported
    and its case run again.

    On local processes the kernels the cases need are compiled here, if not cached yet,
    before the workers start, so that no two workers compile the same kernel at the
    same time. Where the workers are forked (Linux, see
    :func:`ltdsim._workers.process_executor`), this process also loads the kernels and
    rehearses a case in miniature first, so that every worker starts with the imports
    and kernels a case needs instead of loading them again; elsewhere each spawned
    worker loads them itself.
    """
    out = Path(out)
    (out / "cases").mkdir(parents=True, exist_ok=True)
    _remove_partial_files(out, notice)
    skip = finished(out, sweep, retry_failed, extras, keep_results, notice)
    todo = [c for c in sweep.cases if c.id not in skip]
    total = len(sweep.cases)
    done = len(skip)
    local = bool(todo) and not scheduler
    fork = local and fork_possible()
    if local:
        warm_cases(sweep, todo, on_compile, load=fork)
    if fork:
        rehearse(sweep.scenario(todo[0]))
    if progress is not None:
        progress(done, total, "")
    if todo:
        executor, close = _executor(scheduler, workers, len(todo), fork)
        try:
            futures = {}
            for case in todo:
                sc = sweep.scenario(case)
                fut = executor.submit(run_case, sc.to_dict(), case.id, keep_results,
                                      tuple(extras))
                futures[fut] = (case, fingerprint(sc, extras))
            for fut in cf.as_completed(futures):
                case, fp = futures[fut]
                try:
                    record = fut.result()
                except Exception as exc:  # noqa: BLE001 - lost worker, cancelled, ...
                    record = {"id": case.id, "status": "lost",
                              "error": f"{type(exc).__name__}: {exc}"}
                _write_case(out, case, fp, record)
                done += 1
                if progress is not None:
                    progress(done, total, case.id)
        finally:
            close()
    return summary_table(out, sweep)


def warm_cases(sweep: Sweep, cases: list[Case], on_compile=None, load: bool = False) -> float:
    """Compile the kernels ``cases`` need that are not in numba's on-disk cache yet;
    returns the seconds spent compiling. Kernels already cached are loaded here only
    with ``load`` (for workers forked from this process); otherwise this process only
    hands the cases to the workers, which load them themselves.

    The kernel and its argument types depend on the solver (fixed-step or adaptive),
    not on the values, so one case of each kind stands for all."""
    from ltdsim.engine.warmup import scenario_kernels, warm_up

    kinds = {}
    for case in cases:
        sc = sweep.scenario(case)
        kinds.setdefault(sc.solver.adaptive, sc)
    try:
        calls = scenario_kernels(kinds.values())
    except LtdsimError:  # the case fails in its worker, with its own record
        return 0.0
    return warm_up(calls, on_compile, load=load)


def fork_possible() -> bool:
    """True where a sweep's local workers are forked from this process (Linux, no other
    thread than those registered to pause: see :mod:`ltdsim._workers`)."""
    import multiprocessing
    import sys

    return sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods()


def rehearse(scenario: Scenario) -> None:
    """Run ``scenario`` for a few output samples through the worker's code
    (:func:`run_case`), so that the modules a case imports on first use (the dataset's,
    the summary's and the phase norms', among them xarray's check for dask arrays, about
    0.25 s of CPU) are loaded in this process before its workers are forked from it.
    Its record is not kept; a failure here is left for the real case to report."""
    sv = scenario.solver
    short = min(sv.t_end, 20 * sv.output_interval)
    try:
        run_case(scenario.with_overrides({"solver.t_end": short}).to_dict(), "rehearsal")
    except LtdsimError:
        pass


def _executor(scheduler, workers, n_cases: int = 0, fork: bool = False):
    if scheduler:
        from distributed import Client

        client = Client(scheduler)
        return client.get_executor(), client.close
    from ltdsim._workers import process_executor

    n = workers or os.cpu_count() or 1
    if n_cases:
        n = min(n, n_cases)  # (a forking pool starts all its workers at once)
    ex = process_executor(n, fork=fork)  # its workers end when this process dies
    return ex, lambda: ex.shutdown(wait=True, cancel_futures=True)


def _write_case(out: Path, case: Case, fp: str, record: dict) -> None:
    """Write a case's record (sealed with its content hash; with the size and content
    hash of its time series when one is kept), each file atomically, the time series
    first: a record on disk always describes files that are complete."""
    from ltdsim.results.io import save_result

    result = record.pop("result", None)
    if result is not None:
        nc = save_result(result, result_path(out, case.id))
        record["result_file"] = file_record(nc, out)
    record.update(fingerprint=fp, overrides=case.overrides)
    with atomic_path(case_path(out, case.id)) as tmp:
        tmp.write_text(sealed_json(record))


def swept_column(key: str) -> str:
    """The summary's header of swept key ``key``: the key as the sweep file spells it
    and its unit from the scenario schema (:func:`ltdsim.scenario.doc.key_unit`),
    ``couplers.default.k3 [N/m]``; ``[-]`` dimensionless, ``[no unit]`` for a key that
    takes none (a choice, a count), ``[unit not known]`` where the schema gives none."""
    from ltdsim.scenario.doc import key_unit

    known, unit = key_unit(key)
    return f"{key} [{unit if unit else 'no unit' if known else 'unit not known'}]"


def swept_values(sweep: Sweep, case: Case) -> dict:
    """``{swept_column(key): value}`` of ``case`` for each swept key: the value its
    overrides give (as the sweep file wrote it), or, for a key a named case does not
    set, the value its scenario has. A value that is not a number or a text (an array)
    is written as JSON."""
    out = {}
    data = None
    for key in sweep.swept:
        if key in case.overrides:
            value = case.overrides[key]
        else:
            if data is None:
                data = sweep.scenario(case).to_dict()
            value = _dotted_get(data, key)
        if not (value is None or isinstance(value, (bool, int, float, str))):
            value = json.dumps(value)
        out[swept_column(key)] = value
    return out


def _dotted_get(data, key: str):
    """The value at dotted ``key`` of a scenario's dictionary, or None."""
    node = data
    for part in key.split("."):
        if isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return None
    return node


def summary_table(out: str | Path, sweep: Sweep) -> pd.DataFrame:
    """One row per case on disk: the value of each swept key (:func:`swept_values`, a
    column per key with its unit), status, RMS speed error, the largest tension and
    compression over all couplers (and per coupler, numbered as people count:
    ``max_tension_coupler1_N`` is coupler 1, behind the lead), the largest
    |acceleration|."""
    out = Path(out)
    rows = []
    for case in sweep.cases:
        p = case_path(out, case.id)
        values = swept_values(sweep, case)
        if not p.is_file():
            rows.append({"case": case.id, **values, "status": "not run"})
            continue
        rec = json.loads(p.read_text())
        row = {"case": case.id, **values, "status": rec["status"], "error": rec.get("error")}
        s = rec.get("summary")
        if s:
            row.update({
                "rms_speed_error_m_s": s["rms_speed_error_m_s"],
                "max_tension_N": max(s["max_tension_N"], default=0.0),
                "max_compression_N": max(s["max_compression_N"], default=0.0),
                "max_abs_acceleration_m_s2": max(s["max_abs_acceleration_m_s2"]),
                "samples_demand_over_adhesion": s["samples_demand_over_adhesion"],
            })
            for j, (t, c) in enumerate(zip(s["max_tension_N"], s["max_compression_N"])):
                row[f"max_tension_coupler{j + 1}_N"] = t
                row[f"max_compression_coupler{j + 1}_N"] = c
        rows.append(row)
    return pd.DataFrame(rows).set_index("case")


CRITERIA = {
    "rms_speed_error": ("rms_speed_error_m_s", "min"),
    "max_tension": ("max_tension_N", "min"),
    "max_compression": ("max_compression_N", "min"),
    "max_acceleration": ("max_abs_acceleration_m_s2", "min"),
}


def best_case(summary: pd.DataFrame, criterion: str = "rms_speed_error") -> str | None:
    """Id of the best finished case by ``criterion`` (see :data:`CRITERIA`), or None when
    no finished case has a value for it (e.g. no speed error without a speed controller)."""
    column, _ = CRITERIA[criterion]
    ok = summary[summary.status == "ok"]
    if ok.empty or column not in ok:
        return None
    values = ok[column].astype(float).dropna()
    return None if values.empty else str(values.idxmin())


def phase_norm_table(out: str | Path, sweep: Sweep) -> pd.DataFrame:
    """Long table of every finished case's phase norms: case, phase, quantity, number
    (coupler or vehicle as people count: coupler 1 behind the lead, vehicle 1 the lead;
    empty for the locomotive force and speed error), value and its unit."""
    from ltdsim.variables import UNITS

    rows = []
    for case in sweep.cases:
        p = case_path(Path(out), case.id)
        if not p.is_file():
            continue
        rec = json.loads(p.read_text())
        for qty, values in rec.get("phase_norms", {}).items():
            if qty in ("phase_start", "phase_end", "samples"):
                continue
            unit = UNITS.get(qty.rsplit("_", 1)[0], "")
            for ph, v in zip(rec["phases"], values):
                if isinstance(v, list):
                    rows += [{"case": case.id, "phase": ph, "quantity": qty, "number": j + 1,
                              "value": x, "unit": unit} for j, x in enumerate(v)]
                else:
                    rows.append({"case": case.id, "phase": ph, "quantity": qty,
                                 "number": None, "value": v, "unit": unit})
    out = pd.DataFrame(rows)
    if len(out):
        out["number"] = out["number"].astype("Int64")
    return out
