"""A run that blows up while its state stays finite stops where it is recorded, naming
what went beyond which physical bound (ltdsim.engine.layout.ABSURD_*), instead of ending
with a 'top speed' of 1e47 m/s."""

from __future__ import annotations

import numpy as np
import pytest

import ltdsim
from ltdsim.engine import run as engine_run
from ltdsim.engine.kernel.recording import _implausible
from ltdsim.engine.layout import (
    ABSURD_DEFLECTION, ABSURD_PRESSURE, ABSURD_SPEED, I_CELLS, I_PIPE,
)
from ltdsim.engine.lowering import lower
from ltdsim.errors import SimulationError

from conftest import PAPER, ROOT


def test_euler_past_its_stability_limit_stops_with_time_place_and_values():
    # explicit Euler at 0.1 s on the study train: its draft modes (about 2.4 Hz) need a
    # step below 2 / omega = 0.066 s; with the pre-check off it diverges within seconds
    sc = ltdsim.load_scenario(PAPER, case="LHHL").with_overrides(
        {"solver.method": "euler", "solver.dt": 0.1, "solver.output_interval": 0.1,
         "driver.pid.ts": 0.1, "solver.stability_check": False, "solver.t_end": 30.0})
    with pytest.raises(SimulationError) as info:
        ltdsim.simulate(sc)
    err = info.value
    msg = str(err)
    assert "blew up" in msg and "beyond any physical bound" in msg
    assert f"beyond {ABSURD_DEFLECTION:g} m" in msg or f"beyond {ABSURD_SPEED:g} m/s" in msg
    assert "turn solver.stability_check back on" in msg
    assert 0.0 < err.time < 30.0
    assert err.coupler is not None or err.vehicle is not None


def _work(path, **overrides):
    sc = ltdsim.load_scenario(path)
    sc = sc.with_overrides({"solver.t_end": sc.solver.output_interval, **overrides})
    low = lower(sc)
    _, y, _, _, _, common = engine_run._buffers(low, 2, engine_run.recorded(sc))
    tr, cp = common[0], common[1]
    return low, y, tr, cp


def test_the_bounds_are_the_documented_ones():
    low, y, tr, cp = _work(ROOT / "scenarios" / "two-wagons-linear.toml")
    n = low.n
    assert _implausible(y, tr, cp.par) == -1
    y[n + 1] = -0.999 * ABSURD_SPEED
    assert _implausible(y, tr, cp.par) == -1
    y[n + 1] = -1.001 * ABSURD_SPEED  # the rear vehicle, backwards
    assert _implausible(y, tr, cp.par) == 1
    y[n + 1] = 0.0
    y[1] = y[0] + low.d0[0] - 1.001 * ABSURD_DEFLECTION  # coupler 1 stretched apart
    assert _implausible(y, tr, cp.par) == n + 0
    y[1] = y[0] + low.d0[0] + 0.999 * ABSURD_DEFLECTION  # bunched, within the bound
    assert _implausible(y, tr, cp.par) == -1


def test_a_brake_pipe_beyond_any_air_brake_is_implausible():
    low, y, tr, cp = _work(ROOT / "scenarios" / "heavy-haul-fluid.toml")
    n = low.n
    zp, cells = int(low.air_index[I_PIPE]), int(low.air_index[I_CELLS])
    assert cells > 1 and _implausible(y, tr, cp.par) == -1
    assert np.all(y[zp:zp + cells] < ABSURD_PRESSURE)
    y[zp + cells - 1] = 1.01 * ABSURD_PRESSURE
    assert _implausible(y, tr, cp.par) == 2 * n - 1 + cells - 1
    y[zp + cells - 1] = -1.0
    assert _implausible(y, tr, cp.par) == 2 * n - 1 + cells - 1
