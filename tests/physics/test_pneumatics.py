"""The orifice law against the isentropic nozzle written from its energy balance."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from ltdsim.physics.air.pneumatics import critical_ratio, orifice_conductance, orifice_flow

GAMMA, R, T = 1.4, 287.05, 293.15
CDA = 0.8 * math.pi * 0.002**2 / 4  # Cd 0.8, 2 mm diameter, m^2
R_LIN = 0.995


def _nozzle_from_energy(pu, pd):
    """Isentropic nozzle from its energy balance: the throat's speed from the enthalpy
    drop cp T0 (1 - r^((g-1)/g)) and its density rho0 r^(1/g), with the throat pressure
    limited to the critical one (choked flow), kg/s."""
    cp = GAMMA * R / (GAMMA - 1.0)
    r = max(pd / pu, critical_ratio(GAMMA))
    speed = math.sqrt(2.0 * cp * T * (1.0 - r ** ((GAMMA - 1.0) / GAMMA)))
    density = pu / (R * T) * r ** (1.0 / GAMMA)
    return CDA * density * speed


def test_critical_ratio_of_air():
    assert abs(critical_ratio(1.4) - 0.528282) < 1e-6


@settings(deadline=None, max_examples=200)
@given(pu=st.floats(2e5, 1e6), r=st.floats(0.05, R_LIN))
def test_flow_is_the_isentropic_nozzle(pu, r):
    m = orifice_flow(pu, r * pu, CDA, GAMMA, R, T, R_LIN)
    assert math.isclose(m, _nozzle_from_energy(pu, r * pu), rel_tol=1e-9)
    # the same flow the other way is the negative
    assert orifice_flow(r * pu, pu, CDA, GAMMA, R, T, R_LIN) == -m


def test_choked_flow_is_the_sonic_throat():
    pu = 6e5
    sonic = CDA * pu * math.sqrt(GAMMA / (R * T)) * (2 / (GAMMA + 1)) ** (
        (GAMMA + 1) / (2 * (GAMMA - 1)))
    for r in (0.1, 0.3, 0.52):
        assert math.isclose(orifice_flow(pu, r * pu, CDA, GAMMA, R, T, R_LIN), sonic,
                            rel_tol=1e-12)


def test_linear_region_is_continuous_and_linear():
    pu = 5e5
    edge = orifice_flow(pu, R_LIN * pu, CDA, GAMMA, R, T, R_LIN)
    below = orifice_flow(pu, (R_LIN - 1e-9) * pu, CDA, GAMMA, R, T, R_LIN)
    assert math.isclose(edge, below, rel_tol=1e-5)
    g = orifice_conductance(CDA, GAMMA, R, T, R_LIN)
    for dp in np.linspace(1.0, (1 - R_LIN) * pu, 5):
        assert math.isclose(orifice_flow(pu, pu - dp, CDA, GAMMA, R, T, R_LIN), g * dp,
                            rel_tol=1e-9)
    assert orifice_flow(pu, pu, CDA, GAMMA, R, T, R_LIN) == 0.0
    assert orifice_flow(pu, 1e5, 0.0, GAMMA, R, T, R_LIN) == 0.0
