"""Shared builders for small test trains (plain dictionaries, validated by Scenario)."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from reference_rhs import make_rhs
from scipy.integrate import solve_ivp

from ltdsim import Scenario

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "scenarios" / "paper.toml"


def train_dict(masses, *, coupler=None, force=1e5, t_end=10.0, dt=1e-3, output_interval=None,
               method="ode3", davis=None, speed=0.0, gradient=None, powered=(0,),
               static_masses=None) -> dict:
    """A force-driven train of the given masses (kg), generous traction limits."""
    davis = davis or {"a": 0.0, "b": 0.0, "c": 0.0}
    vehicles = []
    for i, m in enumerate(masses):
        v = {"name": f"v{i}", "mass": float(m), "length": 15.0, "davis": dict(davis),
             "powered": i in powered}
        if static_masses is not None:
            v["static_mass"] = float(static_masses[i])
        vehicles.append(v)
    d = {
        "solver": {"method": method, "dt": dt, "t_end": t_end,
                   "output_interval": output_interval or dt},
        "vehicles": vehicles,
        "couplers": {"default": coupler or {"model": "linear", "stiffness": 5e6,
                                            "damping": 0.0, "slack": 0.0}},
        "traction": {"max_force": 1e8, "max_power": 1e9, "adhesion_mass": 1e8},
        "driver": {"mode": "force", "force_profile": [[0.0, float(force)]]},
        "initial": {"speed": speed},
    }
    if gradient is not None:
        d["track"] = {"gradient": gradient}
    return d


def build(d: dict) -> Scenario:
    return Scenario.from_dict(copy.deepcopy(d), "test")


@pytest.fixture(scope="session")
def paper_path() -> Path:
    return PAPER


def smooth_chain(method, dt, t_end=2.0):
    """A smooth linear chain (no slack) driven by a constant force, recorded at the end."""
    return train_dict([20000.0, 10000.0, 15000.0, 10000.0], force=1e5, t_end=t_end, dt=dt,
                      output_interval=t_end, method=method, speed=1.0,
                      coupler={"model": "linear", "stiffness": 1e6, "damping": 2e3, "slack": 0.0})


@pytest.fixture(scope="module")
def chain_reference():
    """The smooth chain's final state from DOP853 at tolerance 1e-13."""
    sc = build(smooth_chain("ode3", 1e-3))
    f, y0 = make_rhs(sc)
    sol = solve_ivp(f, (0.0, 2.0), y0, method="DOP853", rtol=1e-13, atol=1e-13)
    return sol.y[:, -1]


# a wagon's brake: cylinder force (N) and rigging ratio (-)
BRAKE = {"cylinder_force": 3.0e4, "rigging_ratio": 6.0}


def single_braked_wagon(v0, friction, t_end, method="ode3", dt=1e-3):
    """One wagon at v0 (m/s) braked fully at t = 0 with the given friction keys."""
    d = train_dict([9e4], force=0.0, dt=dt, t_end=t_end, speed=v0, method=method,
                   output_interval=0.01)
    d["vehicles"][0]["brake"] = dict(BRAKE, **friction)
    d["brake"] = {"mode": "ecp", "apply_time_constant": 1e-3}
    d["driver"]["brake_profile"] = [[0.0, 1.0]]
    return d


#: a 90 t wagon's brake for the fluid brake's trains (cylinder force N, rigging -, shoes,
#: friction -)
WAGON = {"cylinder_force": 40500.0, "rigging_ratio": 2.6, "shoes": 8, "friction": 0.3}


def fluid_train(n_wagons, commands, *, valve="uic-g", t_end=5.0, out=0.01, method="bs23",
                dt=1e-4, speed=20.0, rtol=1e-4, atol=1e-5, cells=2, brake=None):
    """A loco and ``n_wagons`` 14.4 m braked wagons (90 t), couplers linear, power off."""
    vehicles = [{"name": "loco", "mass": 9e4, "length": 19.0, "powered": True}]
    vehicles.append({"name": "wagon", "count": n_wagons, "mass": 9e4, "length": 14.4,
                     "brake": dict(WAGON, **(brake or {}))})
    return {
        "solver": {"method": method, "dt": dt, "t_end": t_end, "output_interval": out,
                   "rtol": rtol, "atol": atol, "max_step": 0.05},
        "vehicles": vehicles,
        "couplers": {"default": {"model": "linear", "stiffness": 5e7, "damping": 2e5}},
        "traction": {"max_force": 3e5, "max_power": 6.4e6, "adhesion_mass": 9e4},
        "brake": {"model": "fluid", "fluid": {"valve": valve, "cells_per_vehicle": cells}},
        "driver": {"mode": "force", "force_profile": [[0.0, 0.0]],
                   "brake_commands": commands},
        "initial": {"speed": speed},
    }


def short_paper(tmp_path, keep=("LHHL", "HHHH")):
    """The study's scenario file cut to the cases named in keep, written under tmp_path."""
    text = PAPER.read_text()
    head, _, cases = text.partition("[cases.")
    blocks = ("[cases." + cases).split("\n[cases.")
    kept = [b if b.startswith("[cases.") else "[cases." + b for b in blocks
            if any(b.removeprefix("[cases.").startswith(k) for k in keep)]
    p = tmp_path / "paper-short.toml"
    p.write_text(head + "\n".join(kept))
    return p


def cli_refused(*args, code=2) -> str:
    """Run the CLI in-process; assert it refused cleanly (exit code, one error line, no
    traceback) and return the error text."""
    from typer.testing import CliRunner

    from ltdsim.cli.app import app

    res = CliRunner().invoke(app, [str(a) for a in args])
    text = res.stdout + res.stderr
    assert res.exit_code == code, text
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in text
    errors = [line for line in res.stderr.splitlines() if line.startswith("error")]
    assert len(errors) == 1, res.stderr
    return " ".join(res.stderr.split())  # (rich may wrap a long line)


def traced_peak(call):
    """``(result, peak bytes)`` of ``call()`` under tracemalloc (Python's and numpy's
    allocations)."""
    import tracemalloc

    tracemalloc.start()
    try:
        out = call()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return out, peak


# ------------------------------------------------- one compile for the test workers
#: what the workers' kernels are compiled from: the study's fixed-step case (the
#: kernel of the study's subsystems), the fixed-step and adaptive kernels of every
#: subsystem (the induction-drive variant of the study, the heavy-haul trip) and the
#: gear rig (most tests call one of these four; engine.features.KERNEL_SETS)
WARM = ("scenarios/paper.toml", "scenarios/paper-induction.toml", "scenarios/heavy-haul.toml",
        "rig")
_WARM_CODE = """
import sys
from ltdsim.engine.warmup import gear_rig_kernel, scenario_kernels, warm_up
from ltdsim.scenario import load_scenario
w = sys.argv[1]
warm_up([gear_rig_kernel()] if w == "rig" else scenario_kernels([load_scenario(w)]))
"""


@pytest.hookimpl(trylast=True)
def pytest_configure(config):
    """With pytest-xdist's workers (``-n 2``), compile the kernels most tests use once,
    before the workers start, each kernel in a process of its own (side by side on the
    cores); otherwise every worker would compile the same kernels at the same time.
    Reports every 10 s while it compiles; nothing to do when numba's cache holds them."""
    import subprocess
    import sys
    import time

    workers = getattr(config.option, "numprocesses", None)
    if hasattr(config, "workerinput") or not workers or config.option.collectonly:
        return
    from ltdsim.engine.warmup import gear_rig_kernel, scenario_kernels
    from ltdsim.scenario import load_scenario

    def ready(w):
        calls = [gear_rig_kernel()] if w == "rig" else scenario_kernels(
            [load_scenario(ROOT / w)])
        return all(c.ready() for c in calls)

    todo = [w for w in WARM if not ready(w)]
    if not todo:
        return
    say = config.pluginmanager.get_plugin("terminalreporter")
    say = say.write_line if say is not None else print
    say(f"compiling {len(todo)} kernels for the test workers (once per change of the "
        "compiled sources; one to two minutes)")
    t0 = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-c", _WARM_CODE,
                               str(ROOT / w) if w != "rig" else w]) for w in todo]
    try:
        while any(p.poll() is None for p in procs):
            time.sleep(0.5)
            if int(time.perf_counter() - t0) % 10 == 0 and time.perf_counter() - t0 > 1:
                say(f"  compiling: {time.perf_counter() - t0:.0f} s")
                time.sleep(0.5)
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    say(f"compiled in {time.perf_counter() - t0:.0f} s")
