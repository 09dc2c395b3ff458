"""``ltdsim curve-limit``: the largest steady buff force two vehicles can carry on a
curve before a wheel's L/V reaches Nadal's limit (or a wheelset Prud'homme's).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

from ltdsim.errors import ScenarioError
from ltdsim.cli.common import (
    check_number, console, fail, plain_table, say,
)


def curve_limit_cmd(
    file: Annotated[Path, typer.Argument(help="scenario file (TOML) holding the vehicles")],
    coupler: Annotated[int, typer.Option(help="coupler number: coupler k joins vehicles k "
                                              "and k + 1 (1 = behind the lead)")],
    radius: Annotated[float, typer.Option(help="curve radius, m (20 to 1e6)")],
    cant: Annotated[float, typer.Option(help="cant of the outer rail, m (0 to 0.2)")] = 0.0,
    speed: Annotated[float, typer.Option(help="train speed, m/s (0 to 100)")] = 0.0,
    case: Annotated[Optional[str], typer.Option("--case", "-c", help="named case to apply")] = None,
) -> None:
    """The largest steady buff force the two vehicles at a coupler can carry on a curve
    before the worse wheel's L/V reaches Nadal's limit (and, beside it, before a leading
    wheelset reaches Prud'homme's limit): "how hard can we push here". Limits and the
    wheelset share come from the scenario's curving table (its defaults without one)."""
    import math

    from ltdsim.results.safety import curve_limit
    from ltdsim.physics.curving import cant_deficiency
    from ltdsim.scenario import Curving, load_scenario

    try:
        check_number("--radius", radius, 20.0, 1e6, unit="m")
        check_number("--cant", cant, 0.0, 0.2, unit="m")
        check_number("--speed", speed, 0.0, 100.0, unit="m/s")
        sc = load_scenario(file, case=case)
        n = len(sc.vehicles)
        if n < 2:
            raise ScenarioError("--coupler", [("", f"{file} has one vehicle and no coupler")])
        check_number("--coupler", coupler, 1, n - 1, whole=True)
        front, rear = sc.vehicles[coupler - 1], sc.vehicles[coupler]
        for k, v in ((coupler, front), (coupler + 1, rear)):
            problem = v.geometry_problem()
            if problem:
                raise ScenarioError(str(file), [(f"vehicles.{k - 1}", problem)])
    except ScenarioError as exc:
        fail(exc)
        return
    cfg = sc.curving or Curving()
    res = curve_limit(front, rear, radius, cant, speed, cfg.flange_angle, cfg.flange_friction,
                      cfg.leading_share, sc.track.rail_spacing, sc.track.gravity,
                      cfg.prudhomme_alpha)

    def kn(f):
        return "not reached below 50 MN" if math.isinf(f) else f"{f / 1e3:.0f}"

    hd = float(cant_deficiency(speed, 1.0 / radius, cant, sc.track.rail_spacing,
                               sc.track.gravity))
    table = plain_table(f"Curve limit at coupler {coupler}: vehicle {coupler} "
                   f"({front.name}) - vehicle {coupler + 1} ({rear.name})",
                   ("quantity", "value"))
    table.add_row("radius [m]", f"{radius:g}")
    table.add_row("cant [mm]", f"{cant * 1e3:.0f}")
    table.add_row("speed [m/s]", f"{speed:.1f} ({speed * 3.6:.1f} km/h)")
    table.add_row("cant deficiency [mm] (- excess)", f"{hd * 1e3:.0f}")
    table.add_row("Nadal L/V limit [-]", f"{res.limit:.3f} ({cfg.flange_angle:g} deg, "
                                          f"mu {cfg.flange_friction:g})")
    table.add_row("L/V with no coupler force [-]", f"{res.l_over_v_at_zero:.3f}")
    table.add_row("max steady buff force, L/V [kN]", kn(res.buff_force))
    table.add_row("governing vehicle", f"{coupler if res.governing == 'front' else coupler + 1}"
                                       f" ({res.governing} of the pair)")
    table.add_row("Prud'homme limit, front / rear [kN]",
                  f"{res.prudhomme[0] / 1e3:.1f} / {res.prudhomme[1] / 1e3:.1f} "
                  f"(alpha {cfg.prudhomme_alpha:g})")
    table.add_row("max steady buff force, Prud'homme [kN]", kn(res.buff_force_prudhomme))
    console.print(table)
    say("quasi-static, kinematic coupler angles from the vehicle geometry (docs/curving.md); "
         "the same buff force in the couplers on either side of the pair")
