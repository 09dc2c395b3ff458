"""ltdsim: longitudinal train dynamics with nonlinear couplers.

Quick start::

    import ltdsim
    sc = ltdsim.load_scenario("scenarios/paper.toml", case="LHHL")
    ds = ltdsim.simulate(sc.with_overrides({"solver.t_end": 20.0}))
    ds.coupler_force.sel(coupler=0).plot()
"""

from ltdsim._version import __version__  # noqa: E402,F401

from ltdsim import _jitcache  # noqa: E402,F401  (must run before any numba function is defined)

from ltdsim.errors import LtdsimError, ScenarioError, SimulationError  # noqa: E402
from ltdsim.results.io import load_result, save_result  # noqa: E402
from ltdsim.scenario import Scenario, load_scenario  # noqa: E402
from ltdsim.results.simulate import simulate  # noqa: E402

__all__ = [
    "LtdsimError",
    "Scenario",
    "ScenarioError",
    "SimulationError",
    "load_result",
    "load_scenario",
    "save_result",
    "simulate",
]
