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
    check_output_files, console, err_console, fail, plain_table, result_or_scenario, say,
    write_csv,
)


def _phases_or_fail(ds, sc):
    """Phase norms, or a ScenarioError when no declared phase overlaps the record."""
    from ltdsim.analysis.phases import phase_norms

    try:
        return phase_norms(ds, sc)
    except ValueError:
        names = ", ".join(f"{p.name} {p.start:g}-{p.end:g} s" for p in sc.phases)
        raise ScenarioError("phases", [("", f"no phase ({names}) overlaps the record "
                                            f"(0-{float(ds.time[-1]):g} s)")]) from None


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
    from ltdsim.analysis.phases import critical_couplers, traction_check
    from ltdsim.viz.analysis import phase_figures

    try:
        check_folder(output)
        ds, sc = result_or_scenario(file, case, overrides=set_, quiet=quiet)
        norms = _phases_or_fail(ds, sc)
    except (ScenarioError, SimulationError) as exc:
        fail(exc)
        return
    ranking = critical_couplers(norms)
    check = traction_check(ds, sc)
    output.mkdir(parents=True, exist_ok=True)

    def long(dim, var, unit, col):
        frame = norms[[f"{var}_{k}" for k in ("2norm", "infnorm", "rms")]].to_dataframe()
        frame = frame.reset_index()[["phase", dim, *(f"{var}_{k}" for k in ("2norm", "infnorm",
                                                                           "rms"))]]
        frame[dim] = frame[dim] + 1
        return frame.rename(columns={dim: col, **{f"{var}_{k}": f"{var}_{k}_{unit}"
                                                  for k in ("2norm", "infnorm", "rms")}})

    ranked = ranking.assign(coupler=ranking.coupler + 1).rename(columns={"coupler": COUPLER_COL})
    for name, frame in (("phase_norms_couplers.csv", long("coupler", "coupler_force", "N",
                                                          COUPLER_COL)),
                        ("phase_norms_vehicles.csv", long("vehicle", "acceleration", "m_s2",
                                                          VEHICLE_COL)),
                        ("critical_couplers.csv", ranked), ("traction_check.csv", check)):
        write_csv(frame, output / name)
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
    files = phase_figures(ds, output, sc)
    say(f"tables and {len(files)} figures written to {output}")


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
        check_output_files(output, names)
        _, sc = result_or_scenario(file, case, run=False, overrides=set_)
        table = train_modes(sc, which)
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
        save_mode_shapes(table, output / names[1], title=what)
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
    from ltdsim.analysis.spectra import phase_spectra
    from ltdsim.viz.analysis import spectra_figures

    try:
        check_folder(output)
        numbers = None if couplers is None else [int(c) for c in couplers.split(",")
                                                 if c.strip()]
        if numbers is not None and not numbers:
            raise ValueError
        if file.suffix != ".nc":  # refuse bad numbers before simulating
            from ltdsim.scenario import load_scenario

            check_couplers(numbers, load_scenario(file, case=case).n_couplers)
        ds, sc = result_or_scenario(file, case, overrides=set_, quiet=quiet)
        nc = ds.sizes["coupler"]
        check_couplers(numbers, nc)
        if numbers is None:
            numbers = sorted({min(c, nc) for c in STUDY_COUPLERS})
    except (ScenarioError, SimulationError) as exc:  # (a ScenarioError is a ValueError)
        fail(exc)
        return
    except ValueError:
        fail(ScenarioError("--couplers", [("", f"not a list of coupler numbers: {couplers!r}")]))
        return
    which = tuple(c - 1 for c in numbers)  # the library counts from 0
    table = phase_spectra(ds, sc, which)
    output.mkdir(parents=True, exist_ok=True)
    table["coupler"] = table["coupler"] + 1
    write_csv(table.rename(columns={"coupler": COUPLER_COL}), output / "phase_spectra.csv")
    out = plain_table("Coupler force spectra, 0-10 Hz",
                 ("phase", COUPLER_COL, "max [kN]", "at [Hz]", "band RMS [kN]", "main peaks"),
                 justify="left")
    for r in table.itertuples():
        out.add_row(r.phase, str(r.coupler), f"{r.max_N / 1e3:.1f}", f"{r.f_at_max_hz:.1f}",
                    f"{r.band_rms_N / 1e3:.1f}", r.peaks)
    console.print(out)
    files = spectra_figures(ds, output, sc, which)
    say(f"table and {len(files)} figures written to {output}")


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

    from ltdsim.analysis.identify import identify_result
    from ltdsim.results.io import atomic_path
    from ltdsim.analysis.response import ramp_error, step_metrics

    try:
        check_folder(output)
        check_number("--poles", poles, 1, 20, whole=True)
        check_number("--zeros", zeros, 0, poles, whole=True)
        if resample_dt is not None:
            check_number("--resample-dt", resample_dt, 0.0, 10.0, lo_open=True, unit="s")
        ds, _ = result_or_scenario(file, case, overrides=set_, quiet=quiet)
        step = float(ds.time[1] - ds.time[0]) if ds.sizes["time"] > 1 else float("nan")
        if resample_dt is not None and resample_dt < step * (1 - 1e-9):
            raise ScenarioError("--resample-dt", [("", f"must be at least the record's "
                                                       f"interval, {step:g} s (got "
                                                       f"{resample_dt:g})")])
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
    table = plain_table(f"Identified model, Ts = {m.dt:g} s, {poles} poles, {zeros} zeros",
                   ("quantity", "value"))
    for k in ("fpe", "mse", "fit_percent", "prediction_fit_percent", "function_evaluations",
              "cost", "norm_of_step", "first_order_optimality"):
        table.add_row(k, f"{result[k]:.4g}")
    for k in ("RiseTime", "SettlingTime", "Overshoot", "Peak", "PeakTime"):
        table.add_row(f"step {k}", f"{info[k]:.4g}")
    console.print(table)
    console.print("numerator (z^0, z^-1, ...): " + ", ".join(f"{v:.5g}" for v in m.b))
    console.print("denominator: " + ", ".join(f"{v:.5g}" for v in m.a))
    output.mkdir(parents=True, exist_ok=True)
    with atomic_path(output / "sysid.json") as tmp:
        tmp.write_text(json.dumps(result, indent=2))
    say(f"written to {output / 'sysid.json'}")
