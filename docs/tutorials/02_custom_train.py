# ---
# jupyter:
#   jupytext:
#     formats: py:percent
# ---

# %% [markdown]
# # A custom train and its draft gear
#
# A scenario need not be a file: the same tables, written as a Python dictionary, are
# validated by `ltdsim.scenario.scenario_from_data` exactly as a TOML file is (an
# unknown key or a value out of range is refused in one line naming the key). Here a
# locomotive of 80 t pulls three wagons of 50, 60 and 70 t through linear draft gears
# with 20 mm of slack, on level track without running resistance, under a traction
# force that rises to 150 kN in 1 s and then holds.
#
# Once the slack has run out and the oscillations have died away, the train accelerates
# as one body, a = F / M, and Newton's second law applied to the vehicles behind coupler
# j says that coupler carries the force that accelerates them: F_j = m_behind,j a =
# F m_behind,j / M. The run must reproduce that closed form, whatever the gear.

# %%
import numpy as np

import ltdsim
from ltdsim.scenario import scenario_from_data

F = 1.5e5                          # N, the traction force once it has risen
masses = [80e3, 50e3, 60e3, 70e3]  # kg: the locomotive, then the wagons front to rear

train = {
    "name": "custom-four",
    "solver": {"method": "rk4", "dt": 1e-4, "t_end": 15.0, "output_interval": 1e-2},
    "vehicles": [{"name": "loco", "mass": masses[0], "length": 20.0, "powered": True}]
    + [{"name": f"wagon{i}", "mass": m, "length": 15.0} for i, m in enumerate(masses[1:], 1)],
    "couplers": {"default": {"model": "linear", "slack": 0.02,
                             "stiffness": 2e7, "damping": 2e5}},   # N/m, N s/m
    "traction": {"max_force": 3e5, "max_power": 5e6, "adhesion_mass": masses[0]},
    "driver": {"mode": "force", "force_profile": [[0.0, 0.0], [1.0, F], [15.0, F]]},
}
sc = scenario_from_data(train, "custom-four (tutorial)")
ds = ltdsim.simulate(sc)

# %% [markdown]
# ## Steady coupler forces against the closed form
#
# The last three seconds, averaged: the gear's damped oscillation (about 3 Hz, damping
# ratio 0.1 here) has decayed long before.

# %%
def steady(ds, seconds=3.0):
    late = ds.time >= float(ds.time[-1]) - seconds
    return ds.coupler_force.sel(time=late).mean("time").values


M = sum(masses)
closed = np.array([F * sum(masses[j + 1:]) / M for j in range(len(masses) - 1)])
sim = steady(ds)
for n, f_sim, f_cf in zip(ds.coupler_number.values, sim, closed):
    print(f"coupler {n}: simulated {f_sim / 1e3:7.2f} kN, m_behind a = {f_cf / 1e3:7.2f} kN")
a = float(ds.acceleration.sel(vehicle=0)[-300:].mean())
print(f"acceleration {a:.4f} m/s^2, F / M = {F / M:.4f} m/s^2")
assert np.allclose(sim, closed, rtol=5e-3), (sim, closed)
print("STEADY_COUPLER_FORCE_EQUALS_TRAILING_MASS_TIMES_ACCELERATION")

# %% [markdown]
# ## Another gear, the same law
#
# Swap the linear gear for the study's simplified nonlinear gear (its Eq. 9: a recoil
# stiffness k1 in buff, a linear k3 and a fading nonlinear k2 in draft; the stiffnesses
# of scenarios/short-train.toml, with more damping) by `with_overrides`, the dotted keys
# of `--set`. The transient changes, the steady forces do not: they are Newton's law,
# not the gear's.

# %%
gear = {"model": "simplified", "slack": 0.02, "damping": 1e5,       # m, N s/m
        "k1": 8.265776e6, "k2": 1.856364e6, "k3": 3.4748e6, "v_c": 0.6}  # N/m, m
dw = ltdsim.simulate(sc.with_overrides({"couplers.default": gear}))
sim_w = steady(dw)
for n, f_sim, f_cf in zip(dw.coupler_number.values, sim_w, closed):
    print(f"simplified gear, coupler {n}: {f_sim / 1e3:7.2f} kN (closed form {f_cf / 1e3:7.2f} kN)")
print(f"largest tension: linear gear {float(ds.max_coupler_force.max()) / 1e3:.1f} kN, "
      f"simplified gear {float(dw.max_coupler_force.max()) / 1e3:.1f} kN")
assert np.allclose(sim_w, closed, rtol=5e-3), (sim_w, closed)
