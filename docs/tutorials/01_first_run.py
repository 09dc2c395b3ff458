# ---
# jupyter:
#   jupytext:
#     formats: py:percent
# ---

# %% [markdown]
# # First run: simulate a case and read its result
#
# This tutorial runs the study's train (a locomotive and nine wagons, scenario
# `scenarios/paper.toml`) for 20 s of case LHHL, then reads the result, an
# `xarray.Dataset`, the way an engineer would: peaks per coupler, the speed error, one
# vehicle's history, and the file on disk. It takes a few seconds once the kernels are
# compiled (the very first run of ltdsim compiles them, about two minutes).
#
# Run it from anywhere: the scenario files are found beside the installed package (an
# editable install, `pip install -e .`), and the result is written to `results/` under
# the current folder.

# %%
from pathlib import Path

import numpy as np

import ltdsim

SCENARIOS = Path(ltdsim.__file__).resolve().parents[2] / "scenarios"

sc = ltdsim.load_scenario(SCENARIOS / "paper.toml", case="LHHL")
sc = sc.with_overrides({"solver.t_end": 20.0})   # dotted keys, validated like the file
ds = ltdsim.simulate(sc)
print(ds.sizes)

# %% [markdown]
# ## Peaks per coupler
#
# The Python API indexes couplers from 0; `coupler_number` counts from 1 as the study
# does (coupler 1 joins vehicles 1 and 2). Forces are in N, + tension.
# `max_coupler_force` is the largest force over every integration step, not only over
# the recorded samples, so it is at least the largest recorded sample.

# %%
peaks = ds.max_coupler_force.values
for n, f_top, f_low in zip(ds.coupler_number.values, peaks, ds.min_coupler_force.values):
    print(f"coupler {n}: largest tension {f_top / 1e3:7.1f} kN, "
          f"largest compression {max(-f_low, 0.0) / 1e3 + 0.0:6.1f} kN")
recorded = ds.coupler_force.max("time").values
assert np.all(peaks >= recorded - 1e-6 * np.abs(recorded).max())

# %% [markdown]
# ## The speed controller
#
# The PID follows the scenario's speed profile; its error is recorded in m/s.

# %%
rms = float(np.sqrt((ds.speed_error ** 2).mean()))
print(f"RMS speed error over 20 s: {rms:.3f} m/s")
lead = ds.velocity.sel(vehicle=0)
print(f"lead vehicle at 20 s: {float(lead[-1]):.2f} m/s "
      f"(reference {float(ds.speed_reference[-1]):.2f} m/s)")

# %% [markdown]
# ## A check anyone can make: position is the integral of velocity
#
# The kernel integrates velocity and position together; the trapezoidal integral of the
# recorded velocity of the last vehicle must give its recorded travel, to within the
# trapezoid rule's error at the recording interval.

# %%
t = ds.time.values
v = ds.velocity.sel(vehicle=ds.sizes["vehicle"] - 1).values
x = ds.position.sel(vehicle=ds.sizes["vehicle"] - 1).values
travel = x[-1] - x[0]
integral = float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)))
print(f"last vehicle: travel {travel:.4f} m, integral of its velocity {integral:.4f} m")
assert abs(travel - integral) < 1e-3 * max(abs(travel), 1.0)
print("POSITION_IS_INTEGRAL_OF_VELOCITY")

# %% [markdown]
# ## Save and load
#
# `save_result` writes netCDF-4 atomically (a temporary name, then a rename);
# `load_result` reads it back with every unit and the scenario in the attributes.

# %%
path = ltdsim.save_result(ds, "results/first-run.nc") or "results/first-run.nc"
back = ltdsim.load_result("results/first-run.nc")
print(back.coupler_force.attrs.get("units"), back.coupler_force.shape)
assert np.array_equal(back.coupler_force.values, ds.coupler_force.values)
