"""The lumped brake calibrated from the fluid brake (ltdsim.analysis.calibration and the
valve presets' [lumped] tables): the cheap model's stopping distance against the fluid
model's, within the 3 % band the AAR allows a stopping-distance prediction. Emergencies
only: the constants are an emergency's (a full service's slower wave and fill would need
constants of their own; docs/airbrake.md)."""

import pytest

import ltdsim
from ltdsim.analysis.calibration import lumped_from_fluid, lumped_twin
from ltdsim.engine.lowering import service_pressure
from ltdsim.data import load_preset
from ltdsim.physics.air import brakevalves as bv
from ltdsim.results.summary import stopping

from conftest import ROOT

SCEN = ROOT / "scenarios"
BAND = 0.03  # the AAR's accuracy band for a predicted stopping distance, -


def _distance(ds):
    return stopping(ds)["stopping_distance_m"]


@pytest.mark.parametrize("path, case, overrides", [
    ("uic-freight.toml", None, {}),                                # calibrated on (uic-g)
    ("heavy-haul-fluid.toml", "emergency-remote", {}),             # calibrated on (aar)
    ("heavy-haul-fluid.toml", "emergency-lead", {}),               # not calibrated on
    ("uic-freight.toml", None, {"brake.fluid.valve": "uic-p"}),    # calibrated on (uic-p)
])
def test_the_calibrated_lumped_brake_stops_where_the_fluid_brake_does(path, case, overrides):
    sc = ltdsim.load_scenario(SCEN / path, case=case)
    if overrides:
        sc = sc.with_overrides(overrides)
    if case is not None and case.startswith("emergency"):
        sc = sc.with_overrides({"solver.t_end": 70.0})
    fluid = _distance(ltdsim.simulate(sc))
    twin = lumped_twin(sc)
    assert twin.brake.model == "lumped" and twin.brake.calibration is not None
    lumped = _distance(ltdsim.simulate(twin))
    assert lumped == pytest.approx(fluid, rel=BAND)


def test_the_shipped_constants_are_what_the_fluid_brake_measures_now():
    """Re-measured on the UIC freight train's emergency, the uic-g preset's [lumped]
    table holds (to 2 % and 1 m/s): the table is the measurement, not a tuning."""
    sc = ltdsim.load_scenario(SCEN / "uic-freight.toml")
    k = lumped_from_fluid(ltdsim.simulate(sc), sc)
    shipped = load_preset("brakes", "uic-g")["lumped"]
    assert k["propagation_speed"] == pytest.approx(shipped["propagation_speed"], abs=1.0)
    for key in ("apply_time_constant", "emergency_level", "minimum_level"):
        assert k[key] == pytest.approx(shipped[key], rel=0.02), key


def test_service_pressures_follow_the_valve_laws():
    """An AAR valve's 26 psi full service equalises at about 64 psi and its 6 psi minimum
    gives Boyle's 6 x V_aux / V_cyl; a UIC distributor's full service is its 3.8 bar."""
    psi = 6894.76
    aar = load_preset("brakes", "aar")
    cv, dv = bv.control_valve_row(aar["control_valve"]), bv.driver_valve_row(aar["driver_valve"])
    assert service_pressure(cv, dv, 26 * psi) == pytest.approx(64 * psi, abs=1.0 * psi)
    va, vc = cv[bv.CVP_VAUX], cv[bv.CVP_VCYL]
    assert service_pressure(cv, dv, 6 * psi) == pytest.approx(6 * psi * va / vc, rel=1e-9)
    uic = load_preset("brakes", "uic-g")
    cv, dv = bv.control_valve_row(uic["control_valve"]), bv.driver_valve_row(uic["driver_valve"])
    assert service_pressure(cv, dv, 1.5e5) == pytest.approx(3.8e5)
