"""`ltdsim study`: the whole study reproduced as one report (paper §3-5).

Stages, each cached in ``<out>/cache`` by a hash of what it was computed from and of
ltdsim's own code (so a re-run reuses finished stages, an interrupted study resumes, and
a new version of ltdsim recomputes; the sweep also resumes case by case):

1. reduction: the simplified coupler fitted to the low and high friction gears (Table 1,
   Fig. 3);
2. sweep: every case of the scenario, with identification, step metrics and spectra per
   case (Tables 2, 3, 4);
3. base: the base case's time series (netCDF), phase norms (Table 5), speed tracking,
   relative motion, forces and traction curve (Fig. 4-7), spectra and spectrogram of the
   critical couplers (Tables 6-7, Fig. 9);
4. modal: natural frequencies and mode shapes (Fig. 8);
5. the report: ``index.html`` (self-contained, figures embedded), every table also as CSV.

A report folder remembers the settings it was made with (``study.json``): a study with
other settings (``--set`` overrides, no reduction, another base case) refuses to write
over it unless forced, and a report whose settings differ from the scenario file's
carries a banner saying what differs.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ltdsim._provenance import code_hash
from ltdsim.errors import ScenarioError
from ltdsim.results.io import (atomic_path, file_problem, file_record, read_sealed, save_result,
                       sealed_json)
from ltdsim.scenario import CouplerParams, Scenario, load_scenario

Progress = Callable[[str, str], None]
#: the study's own settings: its base case and the reduction's generation limit (§3, §5)
STUDY_CASE = "LHHL"
STUDY_REDUCTION_MAXITER = 1000
#: the file in a report folder that records the settings the report was made with
MANIFEST = "study.json"


def _key(*parts) -> str:
    text = json.dumps([code_hash(), *parts], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class _Cache:
    """Each stage's result in ``<out>/cache/<stage>.json``: a record sealed with the hash
    of its content, holding the key the result was computed from and the size and
    content hash of every file the stage wrote. A record or file that is unreadable,
    truncated, emptied, deleted or altered is reported once ("recomputing stage
    <stage>: <why>") and the stage computed again."""

    def __init__(self, out: Path, notice: Callable[[str], None] | None = None):
        self.out = out
        self.dir = out / "cache"
        self.dir.mkdir(parents=True, exist_ok=True)
        self.notice = notice
        self._seen: dict[tuple[str, str], object] = {}  # (stage, key) -> value or None

    def get(self, stage: str, key: str):
        """The cached value of ``stage`` computed from ``key``, or None to compute it."""
        if (stage, key) not in self._seen:  # check (and hash the files) once per run
            self._seen[stage, key] = self._load(stage, key)
        return self._seen[stage, key]

    def _load(self, stage: str, key: str):
        try:
            rec = read_sealed(self.dir / f"{stage}.json")
        except FileNotFoundError:
            return None  # not computed yet
        except ValueError as exc:
            return self._damaged(stage, str(exc))
        if rec.get("key") != key or "value" not in rec:
            return None  # computed from other settings or code: compute, as asked
        for f in rec.get("files", []):
            why = file_problem(f, self.out)
            if why is not None:
                return self._damaged(stage, why)
        return rec["value"]

    def _damaged(self, stage: str, why: str) -> None:
        _say_notice(self.notice, f"recomputing stage {stage}: {why}")
        return None

    def put(self, stage: str, key: str, value, files=()):
        rec = {"key": key, "value": value, "files": [file_record(f, self.out) for f in files]}
        with atomic_path(self.dir / f"{stage}.json") as tmp:
            tmp.write_text(sealed_json(rec))
        self._seen[stage, key] = value
        return value


def study_settings(scenario_path: Path, case: str, overrides: dict | None, reduction: bool,
                   reduction_maxiter: int) -> dict:
    """What a report is made from: the scenario file (path and a hash of its content),
    the base case, the overrides, and the model-reduction settings. Two studies are the
    same study when all but the content hash agree (an edited scenario file is a new
    version of the same study)."""
    return {"scenario": str(Path(scenario_path).resolve()),
            "scenario_sha256": hashlib.sha256(Path(scenario_path).read_bytes()).hexdigest(),
            "case": case, "overrides": dict(overrides or {}), "reduction": bool(reduction),
            "reduction_maxiter": int(reduction_maxiter)}


def deviations(settings: dict, scenario: Scenario) -> list[str]:
    """How a study's settings depart from the study as published, in words (empty when
    it is the study's own run of the scenario file)."""
    out = []
    for key, value in settings["overrides"].items():
        try:
            was = _dotted(scenario.to_dict(), key)
        except (KeyError, IndexError, TypeError):
            was = None
        out.append(f"{key} = {value}" + (f" (the scenario file: {was})" if was is not None
                                          else " (set on the command line)"))
    if not settings["reduction"]:
        out.append("model reduction skipped (no Table 1, no Fig. 3)")
    elif settings["reduction_maxiter"] != STUDY_REDUCTION_MAXITER:
        out.append(f"model reduction limited to {settings['reduction_maxiter']} generations "
                   f"(the study: {STUDY_REDUCTION_MAXITER})")
    if settings["case"] != STUDY_CASE:
        out.append(f"base case {settings['case']} (the study's Tables 5-7 and Fig. 5-9 are "
                   f"for {STUDY_CASE})")
    return out


def _dotted(data, key: str):
    for part in key.split("."):
        data = data[int(part)] if isinstance(data, list) else data[part]
    return data


def _check_output(out: Path, settings: dict, force: bool, notice=None) -> None:
    """Refuse to mix a new study into a folder that holds another report (or other
    files), unless ``force``; checked before any work is done. A settings record that
    cannot be read is reported through ``notice`` and written again (the stage caches
    still reuse only what was computed from the same inputs)."""
    if out.exists() and not out.is_dir():
        raise ScenarioError("--output", [("", f"{out} is a file, not a folder")])
    manifest = out / MANIFEST
    if not out.is_dir() or force:
        return
    damaged = None
    try:
        old = json.loads(manifest.read_text())
    except FileNotFoundError:
        old = None
    except (OSError, ValueError) as exc:
        old, damaged = None, ("not valid JSON" if isinstance(exc, ValueError)
                              else exc.strerror or str(exc))
    if old is not None and not isinstance(old, dict):
        old, damaged = None, "not a settings record"
    if damaged and (out / "cache").is_dir():
        # a study's damaged record: the stage caches still guard what is reused
        _say_notice(notice, f"rewriting {manifest} (the settings of the report): {damaged}")
        return
    if old is None:  # (a damaged study.json in a folder without a study's cache too)
        if any(out.iterdir()):
            raise ScenarioError("--output", [("", f"{out} is not empty and holds no ltdsim "
                                                  "study; choose an empty or new folder, or "
                                                  "add --force to write into it")])
        return
    what = [k for k in settings if k != "scenario_sha256" and old.get(k) != settings[k]]
    if what:
        raise ScenarioError("--output", [("", f"{out} holds a report made with other "
                                              f"settings ({', '.join(what)} differ); keep it "
                                              "by choosing another --output, or replace it "
                                              "with --force")])


def _say_notice(notice, text: str) -> None:
    if notice is None:
        logging.getLogger("ltdsim").warning(text)
    else:
        notice(text)


SWEEP_EXTRAS = ("sysid", "spectra")
#: the friction gears the simplified coupler is fitted to (Table 1's low and high sets)
REDUCTION_PRESETS = {"low": "friction-wedge-low", "high": "friction-wedge-high"}


# ------------------------------------------------------------------------- stages
def _reduction_key(maxiter):
    return _key("reduction", maxiter, {k: CouplerParams(preset=v).model_dump()
                                       for k, v in REDUCTION_PRESETS.items()})


def _stage_reduction(out, cache, maxiter, workers):
    from ltdsim.viz.plotting import save_reduction
    from ltdsim.analysis.reduction import Search, reduce_gear

    files = [out / "fig3_reduction_low.png", out / "fig3_reduction_high.png"]
    key = _reduction_key(maxiter)
    hit = cache.get("reduction", key)
    if hit is not None:
        return hit
    rows = {}
    for (level, preset), fig in zip(REDUCTION_PRESETS.items(), files):
        r = reduce_gear(CouplerParams(preset=preset), workers=workers,
                        search=Search(maxiter=maxiter))
        save_reduction(r, fig, title=f"Fig. 3 ({level} set): friction gear vs fitted simplified")
        rows[level] = {**r.parameters, "fit_percent": r.fit_percent, "evaluations": r.evaluations}
    return cache.put("reduction", key, rows, files)


def _sweep_spec(scenario_path, overrides):
    from ltdsim.sweep import core as sw

    spec = sw.load_sweep(scenario_path)
    # the overrides apply after each case's own keys
    return sw.with_overrides(spec, overrides or {})


def _stage_sweep(out, spec, workers, progress, on_compile, notice=None):
    # (no stage cache: the sweep keeps every finished case itself, by fingerprint, and
    # runs again a case whose record is damaged)
    from ltdsim.sweep import core as sw

    sw.run_sweep(spec, out / "sweep", workers=workers, extras=SWEEP_EXTRAS,
                 progress=lambda d, n, c: progress("sweep", f"{d}/{n} cases"),
                 on_compile=on_compile, notice=notice)
    records = {}
    for case in spec.cases:
        try:
            records[case.id] = read_sealed(sw.case_path(out / "sweep", case.id))
        except (OSError, ValueError):  # (only if the file was damaged during this run)
            records[case.id] = {"status": "not run"}
    return records


def _base_key(scenario: Scenario) -> str:
    return _key("base", scenario.to_dict())


def _stage_base(out, cache, scenario: Scenario):
    from ltdsim.analysis.phases import critical_couplers, phase_norms, traction_check
    from ltdsim.viz.analysis import phase_figures
    from ltdsim.viz.plotting import save_overview
    from ltdsim.results.simulate import simulate
    from ltdsim.analysis.spectra import band_share, phase_spectra
    from ltdsim.viz.analysis import spectra_figures
    from ltdsim.results.summary import coupler_summary, run_summary

    nc_path = out / "base_case.nc"
    figs = [out / "fig4_speed_tracking.png", out / "fig5_relative_motion.png",
            out / "fig6_forces.png", out / "fig7_traction_curve.png",
            out / "spectra_per_phase.png", out / "spectrogram.png"]
    key = _base_key(scenario)
    hit = cache.get("base", key)
    if hit is not None:
        return hit
    ds = simulate(scenario)
    save_result(ds, nc_path)
    save_overview(ds, figs[0])
    phase_figures(ds, out, scenario)
    norms = phase_norms(ds, scenario)
    nc = ds.sizes["coupler"]
    # the study's couplers 1, 8 and 9: the first and the last two (0-based indices here)
    critical = sorted({0, max(nc - 2, 0), nc - 1})
    spectra_figures(ds, out, scenario, critical)
    value = {
        "norms": {k: v.values.tolist() for k, v in norms.data_vars.items()},
        "phases": [str(p) for p in norms.phase.values],
        "ranking_rms": critical_couplers(norms, by="rms").to_dict(orient="records"),
        "ranking_peak": critical_couplers(norms, by="infnorm").to_dict(orient="records"),
        "traction_check": traction_check(ds, scenario).to_dict(orient="records"),
        "spectra": phase_spectra(ds, scenario, critical).to_dict(orient="records"),
        "spectral_share_below_4hz": band_share(ds, scenario, critical, 4.0, 10.0),
        "critical": critical,
        "couplers": coupler_summary(ds).reset_index().to_dict(orient="records"),
        "summary": run_summary(ds),
        "max_abs_acceleration_m_s2": abs(ds.acceleration).max("time").values.tolist(),
        "samples": int(ds.sizes["time"]),
        "diagnosis": _diagnosis(ds, scenario, out / "fig_base_run.png"),
        "alternatives": _alternatives(ds, scenario),
    }
    extra = [Path(value["diagnosis"]["figure"])] if value["diagnosis"] else []
    return cache.put("base", key, value, [nc_path, *figs, *extra])


def _alternatives(ds, scenario: Scenario) -> dict:
    """The base case again under two changes that test what its numbers rest on:

    * ``own_adhesion``: the traction limited by the adhesion of the powered vehicles'
      own weight instead of the scenario's ``traction.adhesion_mass`` (the study's
      reading, the whole train's); coupler 1's peak |force| per phase (N), the largest
      tension and compression (N), the RMS speed error (m/s), the largest traction (N);
    * ``stretched_start``: the couplings stretched to the end of their slack at the start
      (the study does not say how they start); the largest tension and compression per
      coupler (N) and the largest wagon |acceleration| (m/s^2);
    * ``half_step``: the solver's step halved; every coupler's largest tension and
      compression (N) beside the base run's, whose difference is the spread to quote
      the peaks with.

    Empty for a scenario whose traction has no adhesion mass to change."""
    from ltdsim.analysis.phases import phase_norms, powered_weight_mass
    from ltdsim.errors import LtdsimError
    from ltdsim.results.simulate import simulate
    from ltdsim.results.summary import coupler_summary, run_summary

    def peaks(result):
        cs = coupler_summary(result)
        return {"max_tension_N": cs.max_tension_N.tolist(),
                "max_compression_N": cs.max_compression_N.tolist()}

    out = {}
    try:
        own_sc = scenario.with_overrides(
            {"traction.adhesion_mass": powered_weight_mass(scenario)},
            source="the locomotives' own adhesion")
    except (LtdsimError, ValueError, AttributeError):
        own_sc = None
    if own_sc is not None:
        own = simulate(own_sc)
        norms = phase_norms(own, own_sc)
        summ = run_summary(own)
        out["own_adhesion"] = {
            "adhesion_mass_kg": own_sc.traction.adhesion_mass,
            "phases": [str(p) for p in norms.phase.values],
            "coupler1_peak_N": norms.coupler_force_infnorm.values[:, 0].tolist(),
            "rms_speed_error_m_s": summ["rms_speed_error_m_s"],
            "max_traction_N": summ["max_traction_N"], **peaks(own)}
    if scenario.initial.couplers != "stretched":
        st_sc = scenario.with_overrides({"initial.couplers": "stretched"},
                                        source="a stretched start")
        st = simulate(st_sc)
        acc = np.abs(st.acceleration.values[:, 1:])
        out["stretched_start"] = {**peaks(st), "max_wagon_acceleration_m_s2":
                                  float(acc.max()) if acc.size else float("nan")}
    if not scenario.solver.adaptive:  # (bs23's step follows its tolerances)
        half = scenario.with_overrides({"solver.dt": 0.5 * scenario.solver.dt},
                                       source="half the step")
        out["half_step"] = {"dt_s": half.solver.dt, "base": peaks(ds),
                            "half": peaks(simulate(half))}
    return out


def _jsonable(d: dict) -> dict:
    return {k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in d.items()}


def _diagnosis(ds, scenario: Scenario, figure: Path) -> dict | None:
    """Is the base run violent, and whose is it: the run's diagnostics, the lowest
    closed-loop mode with the PID output read as the locomotive's and as the train's
    acceleration, and the same train under the reading ltdsim used before (sharp
    reference corners, the output times the train's mass) with a figure of both."""
    from ltdsim.analysis.diagnostics import (PAPER_EARLIER_READING, base_run_diagnostics,
                                             closed_loop_modes)
    from ltdsim.viz.analysis import hunt_figure
    from ltdsim.errors import LtdsimError
    from ltdsim.results.simulate import simulate

    if scenario.driver.mode != "speed":
        return None
    try:
        now = base_run_diagnostics(ds, scenario)
        earlier_sc = scenario.with_overrides(PAPER_EARLIER_READING, source="earlier reading")
    except (LtdsimError, ValueError):  # no cruise to judge (a short run), or not the study's
        return None
    earlier = simulate(earlier_sc)
    hunt_figure({"this run (ltdsim's reading)": ds, "alternative reading": earlier}, figure)
    masses = {"locomotive": scenario.vehicles[scenario.consists()[0].vehicles[0]].mass,
              "train": sum(v.mass for v in scenario.vehicles)}
    loop = {}
    for name, mass in masses.items():
        modes = closed_loop_modes(scenario, "draft", mass)
        loop[name] = modes.iloc[0].to_dict() if len(modes) else None
    first = [p for p in scenario.phases if p.name == "acceleration"]
    window = (first[0].start, first[0].end) if first else (0.0, 10.0)

    def coupler1_peak(result):
        return float(abs(result.coupler_force.sel(time=slice(*window)).values[:, 0]).max())

    # a swing is a ring of the train's modes: slower changes (grades, curves) are not one
    f_min = 0.5 * now["held_mode_hz"] if np.isfinite(now["held_mode_hz"]) else None
    return {"now": _jsonable(base_run_diagnostics(ds, scenario, f_min=f_min)),
            "earlier": _jsonable(base_run_diagnostics(earlier, earlier_sc, f_min=f_min)),
            "coupler1_peak_acceleration_N": {"now": coupler1_peak(ds),
                                             "earlier": coupler1_peak(earlier)},
            "acceleration_of": scenario.driver.pid.acceleration_of,
            "closed_loop": loop, "figure": str(figure)}


def _modal_key(scenario: Scenario) -> str:
    return _key("modal", scenario.to_dict())


def _stage_modal(out, cache, scenario: Scenario):
    """Modes of the base case linearised on the couplings' buff branch (a simplified
    coupler's k1, the study's "low") and draft branch (k2 + k3, its "high"), free and
    with the locomotive held, each coupling as the kernel simulates it (its gears in
    series); and the bands of the softest buff and stiffest draft couplings among the
    scenario's cases (the widest the study's parameter space allows)."""
    from ltdsim.engine.couplers import linearised_stiffness
    from ltdsim.analysis.modal import coupling_stiffness, train_modes
    from ltdsim.viz.analysis import save_mode_shapes

    key = _modal_key(scenario)
    files = [out / "fig8_modes.png"]
    hit = cache.get("modal", key)
    if hit is not None:
        return hit
    gears = scenario.coupler(0).gears
    value = {"gears": gears}
    label = {"buff": "k1", "draft": "k2 + k3"}
    tables, stiff = {}, {}
    for branch in ("buff", "draft"):
        try:
            free = train_modes(scenario, branch, "free")
            held = train_modes(scenario, branch, "held")
            k = coupling_stiffness(scenario, branch)
        except ValueError as exc:  # couplers without k1/k2/k3
            value[branch] = {"error": str(exc)}
            continue
        tables[branch], stiff[branch] = free, float(k[0])
        value[branch] = {"free": free.frequency_hz.tolist(), "held": held.frequency_hz.tolist(),
                         "coupling_stiffness_N_m": float(k[0])}
    if tables:
        # one figure, both branches drawn in each panel: with every coupling alike the
        # shapes coincide and the branches differ only in frequency
        first = "buff" if "buff" in tables else "draft"
        second = "draft" if first == "buff" and "draft" in tables else None
        save_mode_shapes(
            tables[first], files[0],
            title="Fig. 8: mode shapes of the free train, case "
                  f"{scenario.case or scenario.name} ({gears} gear{'s' if gears > 1 else ''} "
                  "per coupling); " + ", ".join(
                      f"{b} {label[b]} = {stiff[b] / 1e6:.2f} MN/m" for b in tables),
            names=(first, second or ""), other=tables.get(second) if second else None)
    couplings = ([scenario.with_case(c).coupler(0) for c in scenario.cases]
                 or [scenario.coupler(0)])
    if all(g.model == "simplified" for g in couplings):
        for branch, pick in (("buff", min), ("draft", max)):
            k = pick(linearised_stiffness(g, branch) for g in couplings)
            f = train_modes(scenario, k, "free").frequency_hz.values
            value[f"widest_{branch}"] = {"coupling_stiffness_N_m": k, "band_hz": [f[1], f[-1]]}
    return cache.put("modal", key, value, [f for f in files if f.is_file()])


# ------------------------------------------------------------------------- driver
def _warm_up(out, cache, spec, base_case, reduction, reduction_maxiter, on_compile):
    """Compile (first run only) or load every kernel the stages that are not cached
    yet need, once, before the reduction's and the sweep's worker processes start."""
    from ltdsim.sweep import core as sw
    from ltdsim.engine.warmup import gear_rig_kernel, scenario_kernels, warm_up

    calls = []
    if reduction and cache.get("reduction", _reduction_key(reduction_maxiter)) is None:
        calls.append(gear_rig_kernel())
    # (silent: the sweep stage itself reports a damaged case)
    done = sw.finished(out / "sweep", spec, extras=SWEEP_EXTRAS, notice=lambda text: None)
    runs = [spec.scenario(c) for c in spec.cases if c.id not in done]
    if cache.get("base", _base_key(base_case)) is None:
        runs.append(base_case)
    kinds = {sc.solver.adaptive: sc for sc in runs}  # (one kernel per kind, see warmup)
    calls += scenario_kernels(kinds.values())
    return warm_up(calls, on_compile, parallel=True)


def run_study(scenario_path: str | Path, out: str | Path = "report", *, case: str = STUDY_CASE,
              overrides: dict | None = None, reduction: bool = True,
              reduction_maxiter: int = STUDY_REDUCTION_MAXITER, workers: int | None = None,
              progress: Progress | None = None, force: bool = False,
              on_compile: Callable[[float, bool], None] | None = None,
              notice: Callable[[str], None] | None = None) -> Path:
    """Run every stage and write ``<out>/index.html``; returns its path.

    ``overrides`` (dotted keys) apply to every case after its own keys (e.g. a shorter
    ``solver.t_end`` for a quick look); ``case`` is the base case for phases, spectra and
    modes. A folder that holds a report made with other settings is refused
    (``ScenarioError`` naming ``--output``) unless ``force``; the check comes before any
    work. ``progress(stage, message)`` reports the stages; ``on_compile(elapsed_s,
    done)`` the compile of the kernels on a first run (see
    :func:`ltdsim.engine.warmup.warm_up`; without it the compile is reported as the stage
    "compiling"); ``notice(line)`` each damaged stage, case or file that is computed
    again ("recomputing stage base: report/base_case.nc has 1024 bytes (written with
    ...)"; logged as a warning without it). A stage that is reused says so.
    """
    from ltdsim.engine.preflight import check
    from ltdsim.engine.run import TIME_LIMIT, check_memory, check_time
    from ltdsim.sweep.core import check_sweep_memory, check_sweep_time

    out = Path(out)
    scenario_path = Path(scenario_path)
    base = load_scenario(scenario_path)
    if not base.cases:
        raise ScenarioError(str(scenario_path), [("cases", "the study runs a scenario's "
                                                           "named [cases.*]; this file has "
                                                           "none (scenarios/paper.toml has the "
                                                           "study's 16)")])
    if case not in base.cases:
        raise ScenarioError(str(scenario_path), [("--case", f"unknown case {case!r}; "
                                                            f"available: {', '.join(base.cases)}")])
    # the overrides apply after the case's own keys, as in a sweep
    base_case = base.with_case(case)
    if overrides:
        base_case = base_case.with_overrides(overrides, source="--set")
    spec = _sweep_spec(scenario_path, overrides)
    # every input and the memory the runs need are checked before anything is written
    check_sweep_memory(spec, str(scenario_path), workers)
    check(base_case, "--set" if overrides else f"{scenario_path} case {case}")
    check_memory(base_case, source=f"{scenario_path} case {case}")
    # a case estimated beyond the limit of one run (ltdsim.engine.run.TIME_LIMIT) is
    # refused before the study starts: the study has no option to raise it
    anyway = ("run the cases with `ltdsim sweep FILE --max-time SECONDS` and the base case "
              "with `ltdsim run FILE --case CASE --max-time SECONDS`")
    check_sweep_time(spec, str(scenario_path), TIME_LIMIT, anyway)
    check_time(base_case, TIME_LIMIT, f"{scenario_path} case {case}", anyway)
    settings = study_settings(scenario_path, case, overrides, reduction, reduction_maxiter)
    _check_output(out, settings, force, notice)
    out.mkdir(parents=True, exist_ok=True)
    if force:  # a stale page must never sit beside the new run's files
        (out / "index.html").unlink(missing_ok=True)
    with atomic_path(out / MANIFEST) as tmp:
        tmp.write_text(json.dumps(settings, indent=1))
    cache = _Cache(out, notice)
    say = progress or (lambda stage, msg: None)
    if on_compile is None:
        def on_compile(elapsed, done):
            say("compiling", f"first run only: {elapsed:.0f} s" + (", done" if done else ""))
    _warm_up(out, cache, spec, base_case, reduction, reduction_maxiter, on_compile)
    results = {"settings": settings,
               "deviations": deviations(settings, load_scenario(scenario_path))}

    def announce(stage, key, msg):
        say(stage, f"reused from {cache.dir}" if cache.get(stage, key) is not None else msg)

    if reduction:
        announce("reduction", _reduction_key(reduction_maxiter),
                 "fitting the simplified coupler to the friction gears")
        results["reduction"] = _stage_reduction(out, cache, reduction_maxiter, workers or -1)
    say("sweep", "running the cases")
    results["sweep"] = _stage_sweep(out, spec, workers, say, on_compile, notice)
    announce("base", _base_key(base_case), f"base case {case}: phases, spectra")
    results["base"] = _stage_base(out, cache, base_case)
    announce("modal", _modal_key(base_case), "natural frequencies")
    results["modal"] = _stage_modal(out, cache, base_case)
    say("report", "writing index.html")
    from ltdsim.study.report import write_report

    return write_report(out, results, base_case, case, scenario_path)
