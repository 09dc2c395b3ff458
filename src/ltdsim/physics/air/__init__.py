"""The air brake's physics: the brake pipe's unsteady flow on a finite-volume grid
(brakepipe), orifices and volumes (pneumatics), the driver's brake valve and the
control valves with their reservoirs and cylinder (brakevalves), and the shoe's
friction and retarding force (brakes).

Pure compiled functions of numbers in SI units (Pa absolute inside, kg/s, m^3). May
import ``ltdsim.physics``'s own helpers and the base modules (the valve presets are
data files).
"""
