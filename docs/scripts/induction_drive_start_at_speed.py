"""A locomotive on the induction drive started at speed: the drive's old start (magnetised
at standstill, foc.drive_init) against its steady state at the speed and demand
(foc.drive_steady, what lowering now uses). Prints the table of
docs/induction-drive-train.md (Start at speed) and writes
docs/figures/induction_drive_start_at_speed.png. Run:
PYTHONPATH=src python docs/scripts/induction_drive_start_at_speed.py"""

from contextlib import contextmanager
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from ltdsim.physics.drive import foc  # noqa: E402
from ltdsim.scenario import Scenario  # noqa: E402
from ltdsim.results.simulate import simulate  # noqa: E402

FIGURES = Path(__file__).resolve().parents[1] / "figures"   # docs/figures
T_END = 2.0  # s


def scenario(speed, notch):
    """The study's locomotive on its six driven axles (66.63 t static, dry rail) carrying
    1000 t (no couplers: a stand-in for the train), no resistance, a constant notch,
    every 0.1 ms step recorded."""
    return Scenario.from_dict({
        "solver": {"method": "ode3", "dt": 1e-4, "t_end": T_END, "output_interval": 1e-4},
        "vehicles": [{"name": "loco", "mass": 1.0e6, "static_mass": 66630.0,
                      "length": 20.0, "davis": {"a": 0.0, "b": 0.0, "c": 0.0},
                      "powered": True}],
        "traction": {"max_force": 8.63e5, "max_power": 1.443e7, "adhesion_mass": 8.7663e5,
                     "drive": "induction", "creep": {"rail": "dry"}},
        "driver": {"mode": "notch", "notch_profile": [[0.0, notch]]},
        "initial": {"speed": speed}})


@contextmanager
def old_start():
    """The start before the change: every drive magnetised at standstill, no torque."""
    steady = foc.drive_steady
    foc.drive_steady = lambda m, c, wm, t_ref, v_dc: foc.drive_init(m, c)
    try:
        yield
    finally:
        foc.drive_steady = steady


def run(speed, notch, old):
    s = scenario(speed, notch)
    if old:
        with old_start():
            return s, simulate(s)
    return s, simulate(s)


def main():
    runs = {}
    print("| speed, m/s | notch | start | peak current, A rms (limit 310) | force, "
          "least / largest, kN | force at 2 s, kN | force below -1 kN |")
    print("|---|---|---|---|---|---|---|")
    for speed in (5.0, 20.0, 30.0):
        for notch in (0, 8):
            for old in (True, False):
                s, ds = run(speed, notch, old)
                runs[speed, notch, old] = ds
                t = ds.time.values
                i = ds.stator_current.values[:, 0]
                f = ds.creep_force.values[:, 0] / 1e3
                neg = t[f < -1.0]
                span = (f"{neg[0] * 1e3:.1f}-{neg[-1] * 1e3:.0f} ms" if neg.size
                        else "never")
                start = "standstill (old)" if old else "steady"
                print(f"| {speed:.0f} | {notch} | {start} | {i.max():.1f} "
                      f"| {f.min():.1f} / {f.max():.1f} | {f[-1]:.1f} | {span} |")
    fig, ax = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    for notch, ls in ((0, "-"), (8, "--")):
        for old, col in ((True, "tab:red"), (False, "tab:blue")):
            ds = runs[20.0, notch, old]
            t = ds.time.values * 1e3
            lab = f"{'old start' if old else 'steady start'}, notch {notch}"
            ax[0].plot(t, ds.stator_current.values[:, 0], ls, color=col, label=lab)
            ax[1].plot(t, ds.creep_force.values[:, 0] / 1e3, ls, color=col, label=lab)
    ax[0].axhline(310.0, color="k", lw=0.8, ls=":", label="current limit 310 A")
    ax[0].set_ylabel("stator current, A rms")
    ax[1].set_ylabel("creep force, kN")
    ax[1].set_xlabel("time, ms")
    ax[1].set_xlim(0, 500)
    ax[0].set_title("Locomotive on the induction drive started at 20 m/s")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURES / "induction_drive_start_at_speed.png", dpi=110)


if __name__ == "__main__":
    main()
