# ---
# jupyter:
#   jupytext:
#     formats: py:percent
# ---

# %% [markdown]
# # A braking study with the fluid brake
#
# `scenarios/uic-freight.toml` is a 740 m European freight train (a locomotive and 50
# loaded wagons with UIC distributors in the goods position) braked with the
# fluid-dynamic air brake: the brake pipe's gas dynamics, the driver's valve and each
# wagon's control valve. To keep this tutorial short the train is cut to six wagons and
# the run to 12 s: an emergency application at 2 s from 100 km/h, power off.
#
# What to expect, physically: the driver's valve vents the pipe at the front, so the
# pipe pressure falls, first at the locomotive and then, a wave travelling at about the
# speed of sound in the pipe, at each wagon behind; each control valve answers the fall
# by filling its brake cylinder from its auxiliary reservoir, and the train slows.

# %%
from pathlib import Path

import numpy as np

import ltdsim
from ltdsim.scenario import read_toml, scenario_from_data

SCENARIOS = Path(ltdsim.__file__).resolve().parents[2] / "scenarios"

data = read_toml(SCENARIOS / "uic-freight.toml")   # the file's tables, as a dictionary
data["vehicles"][1]["count"] = 6                      # six wagons instead of 50
sc = scenario_from_data(data, "uic-freight.toml, six wagons")
sc = sc.with_overrides({"solver.t_end": 12.0, "solver.output_interval": 0.01})  # s
ds = ltdsim.simulate(sc)
print(f"{ds.sizes['vehicle']} vehicles, {ds.sizes['time']} samples")

# %% [markdown]
# ## The brake pipe empties
#
# Pressures are gauge, in Pa (`brake_pipe_pressure`, time x vehicle). The pipe starts
# charged (about 5 bar in UIC practice) and an emergency application vents it towards
# zero.

# %%
bp = ds.brake_pipe_pressure
first, last = 0, ds.sizes["vehicle"] - 1
for v in (first, last):
    p = bp.sel(vehicle=v)
    print(f"vehicle {v + 1}: brake pipe {float(p[0]) / 1e5:.2f} bar at 0 s, "
          f"{float(p[-1]) / 1e5:.2f} bar at {float(ds.time[-1]):.0f} s")
assert float(bp.sel(vehicle=last)[-1]) < 0.5 * float(bp.sel(vehicle=last)[0])
print("BRAKE_PIPE_PRESSURE_FALLS")

# %% [markdown]
# ## The wave runs from front to rear
#
# The time at which each wagon's pipe pressure has dropped by 0.5 bar grows along the
# train: the wave has further to go. Its apparent speed is of the order of the speed of
# sound in air (343 m/s at 20 degC); in a pipe this short it comes out higher, as the
# wave's reflection at the closed rear end of the pipe doubles the drop there, so the
# rear wagons reach the 0.5 bar mark sooner than the incident wave alone would bring.


# %%
def time_of_drop(p, drop=0.5e5):
    below = np.nonzero(p.values < float(p[0]) - drop)[0]
    return float(ds.time[below[0]]) if below.size else np.nan


wagons = range(1, ds.sizes["vehicle"])
times = [time_of_drop(bp.sel(vehicle=v)) for v in wagons]
pos = ds.position.isel(time=0).values
for v, t in zip(wagons, times):
    print(f"vehicle {v + 1}: 0.5 bar drop at {t:.3f} s, {pos[0] - pos[v]:.1f} m behind the lead")
assert np.all(np.diff(times) >= 0) and times[-1] > times[0]
speed = (pos[1] - pos[last]) / (times[-1] - times[0]) if times[-1] > times[0] else np.inf
print(f"wave speed between the first and the last wagon: {speed:.0f} m/s")
assert 150.0 < speed < 1000.0   # m/s: a pressure wave, neither instant nor creeping

# %% [markdown]
# ## The cylinders fill and the train slows

# %%
bc = ds.brake_cylinder_pressure.sel(vehicle=last)
v_lead = ds.velocity.sel(vehicle=0)
print(f"last wagon's brake cylinder: {float(bc[-1]) / 1e5:.2f} bar at the end")
print(f"speed: {float(v_lead[0]) * 3.6:.1f} km/h at 0 s, {float(v_lead[-1]) * 3.6:.1f} km/h "
      f"at {float(ds.time[-1]):.0f} s")
print(f"air exhausted: {float(ds.air_exhausted[-1]):.2f} kg")
assert float(bc[-1]) > float(bc[0]) and float(v_lead[-1]) < float(v_lead[0])
