"""Traction: the traction curve with its adhesion, force and power limits (traction),
and the study's induction drive: the machine's dq model (induction), its inverter and
field-oriented control (foc), and the wheel-rail creep force of the driven wheelset
with its slip controller (creep).

Pure compiled functions of numbers in SI units. May import ``ltdsim.physics``'s own
helpers and the base modules (motor and rail presets are data files).
"""
