"""`ltdsim study`: the whole study reproduced as one report (paper §3-5).

Stages, each cached in ``<out>/cache`` by a hash of what it was computed from (so a
re-run reuses finished stages and an interrupted study resumes; the sweep also resumes
case by case):

1. reduction: the simplified coupler fitted to the low and high friction gears (Table 1,
   Fig. 3);
2. sweep: every case of the scenario, with identification, step metrics and spectra per
   case (Tables 2, 3, 4);
3. base: the base case's time series (netCDF), phase norms (Table 5), speed tracking,
   relative motion, forces and traction curve (Fig. 4-7), spectra and spectrogram of the
   critical couplers (Tables 6-7, Fig. 9);
4. modal: natural frequencies and mode shapes (Fig. 8);
5. the report: ``index.html`` (self-contained, figures embedded), every table also as CSV.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from ltdsim import __version__
from ltdsim.io import atomic_path, save_result
from ltdsim.scenario import CouplerParams, Scenario, load_scenario

STAGES = ("reduction", "sweep", "base", "modal", "report")
Progress = Callable[[str, str], None]


def _key(*parts) -> str:
    text = json.dumps([__version__, *parts], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


class _Cache:
    def __init__(self, out: Path):
        self.dir = out / "cache"
        self.dir.mkdir(parents=True, exist_ok=True)

    def get(self, stage: str, key: str):
        p = self.dir / f"{stage}.json"
        if p.is_file():
            rec = json.loads(p.read_text())
            if rec.get("key") == key and all(Path(f).is_file() for f in rec.get("files", [])):
                return rec["value"]
        return None

    def put(self, stage: str, key: str, value, files=()):
        with atomic_path(self.dir / f"{stage}.json") as tmp:
            tmp.write_text(json.dumps({"key": key, "value": value,
                                       "files": [str(f) for f in files]}, default=float))
        return value


def _csv(df: pd.DataFrame, path: Path, index=False) -> Path:
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=index)
    return path


SWEEP_EXTRAS = ("sysid", "spectra")
#: the friction gears the simplified coupler is fitted to (Table 1's low and high sets)
REDUCTION_PRESETS = {"low": "friction-wedge-low", "high": "friction-wedge-high"}


# ------------------------------------------------------------------------- stages
def _reduction_key(maxiter):
    return _key("reduction", maxiter, {k: CouplerParams(preset=v).model_dump()
                                       for k, v in REDUCTION_PRESETS.items()})


def _stage_reduction(out, cache, maxiter, workers):
    from ltdsim.plotting import save_reduction
    from ltdsim.reduce import reduce_gear

    files = [out / "fig3_reduction_low.png", out / "fig3_reduction_high.png"]
    key = _reduction_key(maxiter)
    hit = cache.get("reduction", key)
    if hit is not None:
        return hit
    rows = {}
    for (level, preset), fig in zip(REDUCTION_PRESETS.items(), files):
        r = reduce_gear(CouplerParams(preset=preset), workers=workers, maxiter=maxiter)
        save_reduction(r, fig, title=f"Fig. 3 ({level} set): friction gear vs fitted simplified")
        rows[level] = {**r.parameters, "fit_percent": r.fit_percent, "evaluations": r.evaluations}
    return cache.put("reduction", key, rows, files)


def _sweep_spec(scenario_path, overrides):
    from ltdsim import sweep as sw

    spec = sw.load_sweep(scenario_path)
    if overrides:
        spec = sw.Sweep(spec.base.with_overrides(overrides), spec.cases, spec.source)
    return spec


def _stage_sweep(out, spec, workers, progress, on_compile):
    # (no stage cache: the sweep keeps every finished case itself, by fingerprint)
    from ltdsim import sweep as sw

    sw.run_sweep(spec, out / "sweep", workers=workers, extras=SWEEP_EXTRAS,
                 progress=lambda d, n, c: progress("sweep", f"{d}/{n} cases"),
                 on_compile=on_compile)
    records = {}
    for case in spec.cases:
        p = sw.case_path(out / "sweep", case.id)
        records[case.id] = json.loads(p.read_text()) if p.is_file() else {"status": "not run"}
    return records


def _base_key(scenario: Scenario) -> str:
    return _key("base", scenario.to_dict())


def _stage_base(out, cache, scenario: Scenario):
    from ltdsim.phases import critical_couplers, phase_figures, phase_norms, traction_check
    from ltdsim.plotting import save_overview
    from ltdsim.simulate import simulate
    from ltdsim.spectra import phase_spectra, spectra_figures

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
    ranking = critical_couplers(norms, by="rms")
    nc = ds.sizes["coupler"]
    critical = sorted({int(ranking.query("rank == 1").coupler.mode().iloc[0]), 0,
                       max(nc - 2, 0), nc - 1})
    spectra_figures(ds, out, scenario, critical)
    value = {
        "norms": {k: v.values.tolist() for k, v in norms.data_vars.items()},
        "phases": [str(p) for p in norms.phase.values],
        "ranking": ranking.to_dict(orient="records"),
        "traction_check": traction_check(ds, scenario).to_dict(orient="records"),
        "spectra": phase_spectra(ds, scenario, critical).to_dict(orient="records"),
        "critical": critical,
        "samples": int(ds.sizes["time"]),
    }
    return cache.put("base", key, value, [nc_path, *figs])


def _stage_modal(out, cache, scenario: Scenario):
    from ltdsim.modal import save_mode_shapes, train_modes

    key = _key("modal", scenario.to_dict())
    files = [out / "fig8_modes_low.png", out / "fig8_modes_high.png"]
    hit = cache.get("modal", key)
    if hit is not None:
        return hit
    value = {}
    for which, fig in zip(("low", "high"), files):
        try:
            free = train_modes(scenario, which, 2, "free")
            held = train_modes(scenario, which, 2, "held")
        except ValueError as exc:  # couplers without k1/k2/k3
            value[which] = {"error": str(exc)}
            continue
        save_mode_shapes(free, fig, title=f"Fig. 8: modes with {which} stiffness, 2 gears "
                                          "per coupling")
        value[which] = {"free": free.frequency_hz.tolist(), "held": held.frequency_hz.tolist()}
    return cache.put("modal", key, value, [f for f in files if f.is_file()])


# ------------------------------------------------------------------------- driver
def _warm_up(out, cache, spec, base_case, reduction, reduction_maxiter, on_compile):
    """Compile (first run only) or load every kernel the stages that are not cached
    yet need, once, before the reduction's and the sweep's worker processes start."""
    from ltdsim import sweep as sw
    from ltdsim.warmup import gear_rig_kernel, scenario_kernels, warm_up

    calls = []
    if reduction and cache.get("reduction", _reduction_key(reduction_maxiter)) is None:
        calls.append(gear_rig_kernel())
    done = sw.finished(out / "sweep", spec, extras=SWEEP_EXTRAS)
    runs = [spec.scenario(c) for c in spec.cases if c.id not in done]
    if cache.get("base", _base_key(base_case)) is None:
        runs.append(base_case)
    kinds = {sc.solver.adaptive: sc for sc in runs}  # (one kernel per kind, see warmup)
    calls += scenario_kernels(kinds.values())
    return warm_up(calls, on_compile)


def run_study(scenario_path: str | Path, out: str | Path = "report", *, case: str = "LHHL",
              overrides: dict | None = None, reduction: bool = True,
              reduction_maxiter: int = 1000, workers: int | None = None,
              progress: Progress | None = None,
              on_compile: Callable[[float, bool], None] | None = None) -> Path:
    """Run every stage and write ``<out>/index.html``; returns its path.

    ``overrides`` (dotted keys) apply to every case (e.g. a shorter ``solver.t_end`` for
    a quick look); ``case`` is the base case for phases, spectra and modes.
    ``progress(stage, message)`` reports the stages; ``on_compile(elapsed_s, done)``
    the compile of the kernels on a first run (see :func:`ltdsim.warmup.warm_up`;
    without it the compile is reported as the stage "compiling").
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cache = _Cache(out)
    say = progress or (lambda stage, msg: None)
    base = load_scenario(scenario_path)
    if overrides:
        base = base.with_overrides(overrides)
    base_case = base.with_case(case) if case in base.cases else base
    spec = _sweep_spec(scenario_path, overrides)
    if on_compile is None:
        def on_compile(elapsed, done):
            say("compiling", f"first run only: {elapsed:.0f} s" + (", done" if done else ""))
    _warm_up(out, cache, spec, base_case, reduction, reduction_maxiter, on_compile)
    results = {}
    if reduction:
        say("reduction", "fitting the simplified coupler to the friction gears")
        results["reduction"] = _stage_reduction(out, cache, reduction_maxiter, workers or -1)
    say("sweep", "running the cases")
    results["sweep"] = _stage_sweep(out, spec, workers, say, on_compile)
    say("base", f"base case {case}: phases, spectra")
    results["base"] = _stage_base(out, cache, base_case)
    say("modal", "natural frequencies")
    results["modal"] = _stage_modal(out, cache, base_case)
    say("report", "writing index.html")
    from ltdsim.report import write_report

    return write_report(out, results, base_case, case, Path(scenario_path))


def figure_html(path: Path, caption: str) -> str:
    """An ``<figure>`` with the PNG embedded (base64), so the page works offline."""
    data = base64.b64encode(Path(path).read_bytes()).decode()
    return (f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def table_html(df: pd.DataFrame, digits: int = 4) -> str:
    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return "" if not np.isfinite(v) else f"{v:.{digits}g}"
        return html.escape(str(v))
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in df.columns)
    body = "".join("<tr>" + "".join(f"<td>{fmt(v)}</td>" for v in row) + "</tr>"
                   for row in df.itertuples(index=False))
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


