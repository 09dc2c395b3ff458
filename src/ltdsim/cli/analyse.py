"""``ltdsim phases|modal|spectrum|sysid``: the study's analyses of one run (phase norms
and critical couplers, the train's modes, coupler-force spectra, the identified transfer
function), each writing its tables and figures into a folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from ltdsim.errors import ScenarioError, SimulationError
from ltdsim.cli.common import (
    COUPLER_COL, CaseOpt, QuietOpt, SetOpt, VEHICLE_COL, check_folder, check_number,
    console, err_console, fail, plain_table, result_or_scenario, say,
    simulate_shown, write_csv,
)
from ltdsim.results.outputs import check_outputs, record_outputs


def _analysed(file: Path, case, set_, quiet: bool, check):
    """``(dataset, scenario)`` of ``file`` as :func:`result_or_scenario` gives them, with
    ``check(scenario, record)`` refusing what the analysis cannot work on: for a scenario
    file before it is simulated (``record`` then holds only the time axis the run will
    record) and again on the record itself."""
    if file.suffix == ".nc":
        ds, sc = result_or_scenario(file, case, overrides=set_, quiet=quiet)
    else:
        _, sc = result_or_scenario(file, case, run=False, overrides=set_)
        check(sc, _planned_record(sc))
        ds = simulate_shown(sc, quiet, file, "--set" if set_ else None)
    check(sc, ds)
    return ds, sc


def _planned_record(sc):
    """The time axis (s) a run of ``sc`` records, as a dataset without variables."""
    import numpy as np
    import xarray as xr

    sv = sc.solver
    n = sv.n_steps // sv.record_every + 1
    return xr.Dataset(coords={"time": np.arange(n) * (sv.record_every * sv.dt)})


def _needs_couplers(file: Path, sc, command: str, why: str = "") -> None:
    """Refuse a train without a coupler (one vehicle)."""
    if sc.n_vehicles < 2:
        raise ScenarioError(str(file), [("vehicles", f"ltdsim {command} needs at least 2 "
                                                     f"vehicles (one coupler){why}; the "
                                                     f"train has {sc.n_vehicles}")])


def _windows(file: Path, sc, rec, step: bool = False):
    """The phases (name, start s, end s) of the record ``rec``, refused when none of the
    declared ones overlaps it; and the sampling interval of the record (s) when
    ``step``."""
    from ltdsim.analysis.phases import phases_of

    t = rec.time.values
    phases = phases_of(rec, sc)
    if not phases:
        names = ", ".join(f"{p.name} {p.start:g}-{p.end:g} s" for p in sc.phases)
        raise ScenarioError(str(file), [("phases", f"no phase ({names}) overlaps the "
                                                   f"record ({t[0]:g}-{t[-1]:g} s)")])
    if not step:
        return phases
    if t.size < 2:
        raise ScenarioError(str(file), [("solver.t_end", f"the record holds {t.size} "
                                                         "sample; give a run of at least "
                                                         "two output intervals")])
    return phases, float(t[1] - t[0])


def _window_key(sc) -> str:
    """The scenario key that sets the analysis windows."""
    return "phases" if sc.phases else "solver.t_end"


def _needs_variables(file: Path, sc, rec, command: str, names) -> None:
    """Refuse a run that does not record a variable of ``names`` the analysis reads: a
    scenario whose ``solver.record`` leaves it out (before the run), or a saved result
    without it."""
    from ltdsim.engine.run import recorded
    from ltdsim.variables import BY_NAME, RECORD_ARRAYS

    if rec.data_vars:  # a result: what it holds
        missing = [v for v in names if v not in rec]
    else:  # the run to come: what solver.record keeps
        kept = {v for k in recorded(sc) for v in RECORD_ARRAYS[k]}
        missing = [v for v in names if BY_NAME[v].record and v not in kept]
    if not missing:
        return
    held = ", ".join(sc.solver.record or ()) or "the train signals only"
    raise ScenarioError(str(file), [("solver.record", (
        f"ltdsim {command} reads {', '.join(missing)}, which "
        + ("this result does not hold" if rec.data_vars else "the run would not record")
        + f" (solver.record: {held}); add {'them' if len(missing) > 1 else 'it'} to "
        "solver.record or leave solver.record out"))])


def _check_finite(file: Path, ds, var: str, command: str, columns=None,
                  dim: str = "") -> None:
    """Refuse a recorded ``var`` (of the ``columns`` of ``dim``, 0-based) that holds a
    value that is not finite, naming the first such sample (time, coupler or vehicle
    counted from 1)."""
    import numpy as np

    if var not in ds:
        return  # (the analysis names what it misses itself)
    x = ds[var].values
    if x.ndim == 2 and columns is not None:
        x = x[:, list(columns)]
    bad = ~np.isfinite(x)
    if not bad.any():
        return
    k = int(np.argmax(bad.reshape(bad.shape[0], -1).any(axis=1)))
    where = f"t = {float(ds.time.values[k]):g} s"
    if x.ndim == 2:
        j = int(np.argmax(bad[k]))
        number = (list(columns)[j] if columns is not None else j) + 1
        where += f", {dim} {number}"
        value = x[k, j]
    else:
        value = x[k]
    raise ScenarioError(str(file), [(var, f"not finite ({value}) at {where} (the first such "
                                          f"sample); ltdsim {command} needs finite values: "
                                          "simulate the scenario again")])


def _written_or_fail(write) -> None:
    """Run ``write()`` (the outputs, checked before the work); a disk that fills up
    meanwhile is one line, exit code 3."""
    try:
        write()
    except OSError as exc:
        from rich.markup import escape

        err_console.print(f"[bold red]error (writing failed):[/] "
                          f"{escape(str(exc.filename or exc))}: "
                          f"{escape(exc.strerror or str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(3) from None


#: what ``phases`` reads: the norms' forces and accelerations, the figures' motion
PHASES_READS = ("coupler_force", "acceleration", "speed_error", "velocity",
                "relative_position", "relative_velocity")


def phases(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/phases"),
    quiet: QuietOpt = False,
) -> None:
    """Phase norms (study Table 5), critical couplers, traction check and Fig. 5-7.

    The phases are the scenario's phases tables; without them the whole run is one
    phase."""
    from ltdsim.analysis.phases import critical_couplers, phase_norms, traction_check
    from ltdsim.viz.analysis import phase_figures

    def check(sc, rec):
        import numpy as np

        _needs_couplers(file, sc, "phases", ": it ranks the couplers")
        _needs_variables(file, sc, rec, "phases", PHASES_READS)
        t = rec.time.values
        for name, a, b in _windows(file, sc, rec):
            if np.searchsorted(t, b, "right") == np.searchsorted(t, a, "left"):
                raise ScenarioError(str(file), [("phases", f"phase {name} ({a:g}-{b:g} s) "
                                                           "holds no recorded sample (one "
                                                           f"every {t[1] - t[0]:g} s); its "
                                                           "norms need at least 1: widen it "
                                                           "or lower solver.output_interval")])

    try:
        check_folder(output)
        check_outputs(output, PHASES_FILES, "phases")
        ds, sc = _analysed(file, case, set_, quiet, check)
    except (ScenarioError, SimulationError) as exc:
        fail(exc)
        return
    norms = phase_norms(ds, sc)
    ranking = critical_couplers(norms)
    check = traction_check(ds, sc)

    def long(dim, var, unit, col):
        frame = norms[[f"{var}_{k}" for k in ("2norm", "infnorm", "rms")]].to_dataframe()
        frame = frame.reset_index()[["phase", dim, *(f"{var}_{k}" for k in ("2norm", "infnorm",
                                                                           "rms"))]]
        frame[dim] = frame[dim] + 1
        return frame.rename(columns={dim: col, **{f"{var}_{k}": f"{var}_{k}_{unit}"
                                                  for k in ("2norm", "infnorm", "rms")}})

    ranked = ranking.assign(coupler=ranking.coupler + 1).rename(columns={"coupler": COUPLER_COL})
    figures = []

    def write():
        output.mkdir(parents=True, exist_ok=True)
        tables = (("phase_norms_couplers.csv", long("coupler", "coupler_force", "N",
                                                    COUPLER_COL)),
                  ("phase_norms_vehicles.csv", long("vehicle", "acceleration", "m_s2",
                                                    VEHICLE_COL)),
                  ("critical_couplers.csv", ranked), ("traction_check.csv", check))
        for name, frame in tables:
            write_csv(frame, output / name)
        figures.extend(phase_figures(ds, output, sc))
        record_outputs(output, [output / name for name, _ in tables] + figures)

    _written_or_fail(write)
    table = plain_table(f"Largest coupler force |F| per phase [kN], {file}"
                   + (f" [{sc.case}]" if sc.case else ""),
                   (COUPLER_COL, *(str(ph) for ph in norms.phase.values)))
    for j in norms.coupler.values:
        table.add_row(str(j + 1), *[
            f"{norms.coupler_force_infnorm.sel(phase=ph, coupler=j).item() / 1e3:.0f}"
            for ph in norms.phase.values])
    console.print(table)
    top = ranking[ranking["rank"] == 1].set_index(["phase", "criterion"])
    crit = plain_table("Critical coupler per phase: the largest force by peak (largest |F|) and "
                  "by RMS",
                  ("phase", "by peak: coupler", "peak [kN]", "by RMS: coupler", "RMS [kN]"))
    for ph in norms.phase.values:
        pk, rms = top.loc[(ph, "peak")], top.loc[(ph, "RMS")]
        crit.add_row(str(ph), str(int(pk.coupler) + 1), f"{pk.force_N / 1e3:.0f}",
                     str(int(rms.coupler) + 1), f"{rms.force_N / 1e3:.0f}")
    console.print(crit)
    over = int(check.loc[check.phase == "whole run", "samples_demand_over_adhesion"].item())
    say(f"samples where traction demand exceeded adhesion: {over}")
    say(f"tables and {len(figures)} figures written to {output}")


#: the files ``phases`` writes in its folder (ltdsim.viz.analysis.phase_figures' three)
PHASES_FILES = ("phase_norms_couplers.csv", "phase_norms_vehicles.csv",
                "critical_couplers.csv", "traction_check.csv", "fig5_relative_motion.png",
                "fig6_forces.png", "fig7_traction_curve.png")


def modal(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    stiffness: Annotated[str, typer.Option(
        help="the branch every coupling is linearised on: draft (tension; a simplified "
             "coupler's k2 + k3) or buff (compression; its k1), or a coupling stiffness in "
             "N/m")] = "draft",
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/modal"),
) -> None:
    """Natural frequencies and mode shapes of the train (study Fig. 8), linearised as the
    kernel simulates each coupling (its gears in series included: the key gears)."""
    from numpy.linalg import LinAlgError

    from ltdsim.analysis.modal import train_modes
    from ltdsim.viz.analysis import save_mode_shapes

    try:
        check_folder(output)
        if stiffness in ("draft", "buff"):
            which = stiffness
        else:
            try:
                which = float(stiffness)
            except ValueError:
                which = float("nan")
            if not 0.0 < which <= 1e12:
                raise ScenarioError("--stiffness", [("", "must be draft, buff or a coupling "
                                                         "stiffness in (0, 1e12] N/m "
                                                         f"(got {stiffness})")])
        names = (f"modes_{stiffness}.csv", f"mode_shapes_{stiffness}.png")
        check_outputs(output, names, "modal")
        _, sc = result_or_scenario(file, case, run=False, overrides=set_)
        _needs_couplers(file, sc, "modal")
        table = train_modes(sc, which)
    except LinAlgError as exc:  # (a ValueError: scipy's words are no option's)
        fail(ScenarioError(str(file), [("", "the modes could not be computed: scipy's "
                                            "eigensolver failed on the train's masses and "
                                            "coupling stiffnesses ("
                                            f"{' '.join(str(exc).split())}); check the "
                                            "vehicles' masses and --stiffness")]))
        return
    except (ScenarioError, ValueError) as exc:
        fail(exc if isinstance(exc, ScenarioError) else
              ScenarioError("--stiffness", [("", str(exc))]))
        return
    gears = sorted({sc.coupler(j).gears for j in range(sc.n_couplers)})
    what = (f"{stiffness} branch" if isinstance(which, str) else f"{which:.4g} N/m")
    what += ", " + " or ".join(str(g) for g in gears) + " gear(s) per coupling"
    out = plain_table(f"Modes of {file}" + (f" [{sc.case}]" if sc.case else "") + f", {what}",
                 ("mode (1 = lowest)", "frequency [Hz]"))
    for i, f in enumerate(table.frequency_hz):
        out.add_row(str(i + 1), f"{f:.3f}")
    console.print(out)
    n = table.shape[1] - 1
    shapes = table.rename(columns={f"vehicle_{i}": f"vehicle {i + 1}" + (" (lead)" if i == 0
                                                                           else "")
                                   for i in range(n)})
    shapes.index = shapes.index + 1
    shapes.index.name = "mode (1 = lowest)"
    try:  # (checked before the work; a disk that fills up meanwhile still fails here)
        output.mkdir(parents=True, exist_ok=True)
        write_csv(shapes, output / names[0], index=True)
        save_mode_shapes(table, output / names[1], title=what, table_numbers=True)
        record_outputs(output, [output / name for name in names])
    except OSError as exc:
        from rich.markup import escape

        err_console.print(f"[bold red]error (writing failed):[/] "
                          f"{escape(str(exc.filename or output))}: "
                          f"{escape(exc.strerror or str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(3) from None
    say(f"table and mode-shape figure written to {output}")


#: the couplers the study calls critical (its numbering, 1 = behind the lead)
STUDY_COUPLERS = (1, 8, 9)


def spectrum(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    couplers: Annotated[Optional[str], typer.Option(
        help="coupler numbers, comma separated, 1 = behind the lead (1 to n-1); default "
             "1,8,9, the study's critical couplers (on a shorter train the last coupler "
             "stands in for those beyond it)")] = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/spectra"),
    quiet: QuietOpt = False,
) -> None:
    """Coupler force spectra per phase (study Tables 6-7) and a spectrogram."""
    import math

    import numpy as np

    from ltdsim.analysis.spectra import phase_spectra
    from ltdsim.viz.analysis import spectra_figures

    try:
        numbers = None if couplers is None else [int(c) for c in couplers.split(",")
                                                 if c.strip()]
        if numbers is not None and not numbers:
            raise ValueError
    except ValueError:
        fail(ScenarioError("--couplers", [("", f"not a list of coupler numbers: {couplers!r}")]))
        return
    which = []  # the couplers analysed, from 0 (the library's count)

    def check(sc, rec):
        _needs_couplers(file, sc, "spectrum", ": it analyses coupler forces")
        nc = sc.n_couplers
        check_couplers(numbers, nc)
        which[:] = [c - 1 for c in (numbers or sorted({min(c, nc) for c in STUDY_COUPLERS}))]
        phases, dt = _windows(file, sc, rec, step=True)
        # lines 1 / (n dt) apart: the first above 0 Hz within the band, and 3 samples for
        # the straight line removed first (two always lie on it)
        need = max(3, math.ceil(1.0 / (SPECTRUM_BAND_HZ * dt) - 1e-9))
        t = rec.time.values
        for name, a, b in phases:
            n = int(np.searchsorted(t, b - 0.5 * dt, "right") - np.searchsorted(t, a, "left"))
            if n < need:
                what = f"phase {name}" if sc.phases else "the whole run"
                hint = "widen the phase or give a longer run" if sc.phases else \
                    "give a longer run"
                raise ScenarioError(str(file), [(_window_key(sc), (
                    f"{what} ({a:g}-{b:g} s) holds {n} samples (one every {dt:g} s); a "
                    f"spectrum to {SPECTRUM_BAND_HZ:g} Hz needs at least {need} "
                    f"({need * dt:g} s): its first line above 0 Hz, at 1/(samples x "
                    "interval), must lie within the band, and the linear trend removed "
                    f"first leaves nothing of fewer than 3; {hint}"))])
        _needs_variables(file, sc, rec, "spectrum", ("coupler_force", "coupler_deflection"))
        _check_finite(file, rec, "coupler_force", "spectrum", which, "coupler")

    try:
        check_folder(output)
        check_outputs(output, SPECTRUM_FILES, "spectrum")
        ds, sc = _analysed(file, case, set_, quiet, check)
    except (ScenarioError, SimulationError) as exc:
        fail(exc)
        return
    table = phase_spectra(ds, sc, tuple(which), f_max=SPECTRUM_BAND_HZ)
    table = table.drop(columns="coupler").rename(columns={"coupler_number": "coupler"})
    files = []

    def write():
        output.mkdir(parents=True, exist_ok=True)
        write_csv(table.rename(columns={"coupler": COUPLER_COL}), output / SPECTRUM_FILES[0])
        files.extend(spectra_figures(ds, output, sc, tuple(which), f_max=SPECTRUM_BAND_HZ))
        record_outputs(output, [output / SPECTRUM_FILES[0], *files])

    _written_or_fail(write)
    out = plain_table(f"Coupler force spectra, 0-{SPECTRUM_BAND_HZ:g} Hz",
                 ("phase", COUPLER_COL, "max [kN]", "at [Hz]", "band RMS [kN]", "main peaks"),
                 justify="left")
    for r in table.itertuples():
        out.add_row(r.phase, str(r.coupler), f"{r.max_N / 1e3:.1f}", f"{r.f_at_max_hz:.1f}",
                    f"{r.band_rms_N / 1e3:.1f}", r.peaks)
    console.print(out)
    say(f"table and {len(files)} figures written to {output}")


#: the band of the spectra, 0 to this, Hz (the study's Tables 6-7)
SPECTRUM_BAND_HZ = 10.0
#: the files ``spectrum`` writes in its folder (the table first)
SPECTRUM_FILES = ("phase_spectra.csv", "spectra_per_phase.png", "spectrogram.png")


def check_couplers(numbers, n: int) -> None:
    bad = [c for c in numbers or () if not 1 <= c <= n]
    if bad:
        raise ScenarioError("--couplers", [("", f"{', '.join(map(str, bad))} out of range "
                                                f"1-{n}: couplers are numbered 1 to {n} "
                                                "(coupler 1 is behind the lead)")])


def sysid(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) or result (.nc)")],
    case: CaseOpt = None,
    set_: SetOpt = None,
    poles: Annotated[int, typer.Option(help="number of poles")] = 4,
    zeros: Annotated[int, typer.Option(help="number of zeros (feed-through included)")] = 3,
    resample_dt: Annotated[Optional[float], typer.Option(
        help="identify at this sample time, s (default: the record's)")] = None,
    output: Annotated[Path, typer.Option("--output", "-o", help="output folder")] = Path(
        "results/sysid"),
    quiet: QuietOpt = False,
) -> None:
    """Identify the transfer function locomotive force -> acceleration of vehicle 2, the
    first wagon (study Table 3, Appendix II) and its step metrics (Table 4)."""
    import json
    import math

    from ltdsim.analysis.identify import _stable, identify_result
    from ltdsim.results.io import atomic_path
    from ltdsim.analysis.response import ramp_error, step_metrics

    def check(sc, rec):
        _needs_couplers(file, sc, "sysid", ": it identifies locomotive force -> "
                                          "acceleration of vehicle 2")
        t = rec.time.values
        if t.size < 2:
            raise ScenarioError(str(file), [("solver.t_end", f"the record holds {t.size} "
                                                             "sample; give a longer run")])
        step = float(t[1] - t[0])
        if resample_dt is not None and resample_dt < step * (1 - 1e-9):
            raise ScenarioError("--resample-dt", [("", f"must be at least the record's "
                                                       f"interval, {step:g} s (got "
                                                       f"{resample_dt:g})")])
        # (identify_result: decimated by q when resample_dt is above 1.5 intervals)
        q = int(round(resample_dt / step)) if resample_dt and resample_dt > 1.5 * step else 1
        n = -(-t.size // q)
        need = 2 * (poles + zeros + 1 + max(poles, zeros))
        if n < need:
            at = f" every {q * step:g} s (--resample-dt)" if q > 1 else f" (one every {step:g} s)"
            raise ScenarioError(str(file), [("solver.t_end", (
                f"the record holds {n} samples{at}; identifying {poles + zeros + 1} "
                f"parameters ({poles} poles, {zeros} zeros and the feed-through) needs at "
                f"least {need}: the first half estimates, its first {max(poles, zeros)} "
                "samples only start the model and least squares needs at least one "
                "equation per parameter, the second half validates; give a longer run, "
                "fewer --poles or --zeros" + (", or a smaller --resample-dt" if q > 1 else "")))])
        _needs_variables(file, sc, rec, "sysid", ("traction_force", "acceleration"))
        _check_finite(file, rec, "traction_force", "sysid")
        _check_finite(file, rec, "acceleration", "sysid", [1], "vehicle")

    try:
        check_folder(output)
        check_number("--poles", poles, 1, 20, whole=True)
        check_number("--zeros", zeros, 0, poles, whole=True)
        if resample_dt is not None:
            check_number("--resample-dt", resample_dt, 0.0, 10.0, lo_open=True, unit="s")
        check_outputs(output, ("sysid.json",), "sysid")
        ds, _ = _analysed(file, case, set_, quiet, check)
    except (ScenarioError, SimulationError) as exc:
        fail(exc)
        return
    m = identify_result(ds, resample_dt=resample_dt, na=poles, nb=zeros)
    info = step_metrics(m.tf())
    result = {
        "sample_time_s": m.dt, "numerator_z^-1": m.b.tolist(), "denominator_z^-1": m.a.tolist(),
        "fpe": m.fpe, "mse": m.mse, "fit_percent": m.fit_percent,
        "prediction_fit_percent": m.prediction_fit_percent, "function_evaluations": m.evaluations,
        "cost": m.cost, "norm_of_step": m.step_norm, "first_order_optimality": m.optimality,
        "step": {k: float(v) for k, v in info.items()}, "ramp_steady_state_error": ramp_error(m.tf()),
    }
    settles = ("the identified model is unstable (a pole on or outside the unit circle)"
               if not _stable(m.a) else "the identified model's step response does not "
               "settle within python-control's horizon")
    why = {"step": settles,
           "ramp_steady_state_error": "the ramp response does not settle to a steady error "
                                      "(an unstable model, or a DC gain other than 1)",
           "fit_percent": "the validation half's output does not vary (no fit to measure)",
           "prediction_fit_percent": "the validation half's output does not vary (no fit to "
                                     "measure)"}
    nulls = {}

    def finite(key, v):  # JSON has no NaN or Infinity: null, and the reason in "null"
        if isinstance(v, dict):
            return {k: finite(f"{key}.{k}", x) for k, x in v.items()}
        if isinstance(v, float) and not math.isfinite(v):
            nulls[key] = f"{v}: {why.get(key.split('.')[0], 'not a finite number')}"
            return None
        return v

    written = {k: finite(k, v) for k, v in result.items()}
    if nulls:
        written["null"] = nulls
    table = plain_table(f"Identified model, Ts = {m.dt:g} s, {poles} poles, {zeros} zeros",
                   ("quantity", "value"))

    def shown(v):
        return f"{v:.4g}" if math.isfinite(v) else f"{v} (null in sysid.json)"

    for k in ("fpe", "mse", "fit_percent", "prediction_fit_percent", "function_evaluations",
              "cost", "norm_of_step", "first_order_optimality"):
        table.add_row(k, shown(result[k]))
    for k in ("RiseTime", "SettlingTime", "Overshoot", "Peak", "PeakTime"):
        table.add_row(f"step {k}", shown(info[k]))
    console.print(table)
    console.print("numerator (z^0, z^-1, ...): " + ", ".join(f"{v:.5g}" for v in m.b))
    console.print("denominator: " + ", ".join(f"{v:.5g}" for v in m.a))
    for k, reason in nulls.items():
        say(f"{k} is {reason}")

    def write():
        output.mkdir(parents=True, exist_ok=True)
        with atomic_path(output / "sysid.json") as tmp:
            tmp.write_text(json.dumps(written, indent=2, allow_nan=False))
        record_outputs(output, [output / "sysid.json"])

    _written_or_fail(write)
    say(f"written to {output / 'sysid.json'}")
