"""Draft gear and coupler force laws: the linear and the study's simplified coupler
with slack, unilateral contact and solid closure (couplers), the four-stage friction
wedge gear, table gears and the hysteresis band all hysteretic gears share
(draftgear), and the rate-dependent polymer gear (polymer).

Pure compiled functions of numbers in SI units, each law's equation and source in its
docstring. May import ``ltdsim.physics``'s own helpers only.
"""
