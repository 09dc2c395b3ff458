"""Measure the lumped brake's constants on the fluid brake for each valve preset and
print them as the presets' ``[lumped]`` tables (src/ltdsim/data/brakes/*.toml), with
the stopping distances of the fluid run and of its lumped twin
(:mod:`ltdsim.analysis.calibration`).

    PYTHONPATH=src python docs/scripts/lumped_calibration.py

The emergencies measured: ``aar`` on the heavy-haul train with its remote consist venting
(scenarios/heavy-haul-fluid.toml, case emergency-remote), ``uic-g`` and ``uic-p`` on the
UIC freight train (scenarios/uic-freight.toml, its emergency; with the P valve for
``uic-p``).
"""

from __future__ import annotations

from pathlib import Path

import ltdsim
from ltdsim.analysis.calibration import lumped_from_fluid, lumped_twin
from ltdsim.results.summary import stopping

SCEN = Path(__file__).resolve().parents[2] / "scenarios"
CASES = {
    "aar": (SCEN / "heavy-haul-fluid.toml", "emergency-remote", {}),
    "uic-g": (SCEN / "uic-freight.toml", None, {}),
    "uic-p": (SCEN / "uic-freight.toml", None, {"brake.fluid.valve": "uic-p"}),
}


def fluid_case(name: str):
    path, case, overrides = CASES[name]
    sc = ltdsim.load_scenario(path, case=case)
    return sc.with_overrides(overrides) if overrides else sc


def main() -> None:
    rows = []
    for name in CASES:
        sc = fluid_case(name)
        print(f"running {name}: fluid", flush=True)
        fluid = ltdsim.simulate(sc)
        k = lumped_from_fluid(fluid, sc)
        print(f"running {name}: lumped twin", flush=True)
        lumped = ltdsim.simulate(lumped_twin(sc, constants=k))
        sf, sl = stopping(fluid)["stopping_distance_m"], stopping(lumped)["stopping_distance_m"]
        rows.append((name, k, sf, sl))
    for name, k, _sf, _sl in rows:
        print(f"\n# {name}\n[lumped]")
        print(f"propagation_speed = {k['propagation_speed']:.1f}    # m/s")
        print(f"apply_time_constant = {k['apply_time_constant']:.2f}   # s")
        print(f"emergency_level = {k['emergency_level']:.3f}")
        print(f"minimum_level = {k['minimum_level']:.3f}")
    print("\n| valve | stopping distance, fluid (m) | lumped twin (m) | difference |")
    print("|---|---|---|---|")
    for name, _k, sf, sl in rows:
        print(f"| {name} | {sf:.0f} | {sl:.0f} | {100 * (sl - sf) / sf:+.1f} % |")


if __name__ == "__main__":
    main()
