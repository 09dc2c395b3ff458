"""The brake test of a valve preset (``ltdsim brake-test``): the stand test of one braked
vehicle and a train test of the emergency front, each figure beside the window its norm
gives, with pass or fail.

**Stand** (:mod:`ltdsim.engine.brakerig`: one driver's valve, one vehicle's pipe, one
control valve), every time counted from the handle as UIC 540 counts it:

* ``fill``: an emergency from the handle; the time until the cylinder reaches 95 % of its
  final pressure, s;
* ``release``: a full service settled for 60 s, then running; the time until the cylinder
  is down to 0.4 bar (gauge), s;
* ``full-service cylinder`` and ``emergency cylinder``: their final pressures, Pa gauge;
* ``full-service pipe``: the pipe's pressure after a full service, Pa gauge.

**Train**: a locomotive and ``front_train.wagons`` braked wagons of ``front_train.length``
m, the emergency from the lead at each temperature of ``front_temperatures`` (K); the
front's speed end to end (:func:`ltdsim.results.summary.fluid_brake_summary`), m/s.

The windows are data: each preset's ``[brake_test]`` table (src/ltdsim/data/brakes), with
their sources there. A check without a window in the table is measured and shown, not
judged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ltdsim.physics.air import brakevalves as bv

#: the stand's records: every 10 ms, fill and release followed for these times, s
STAND_FILL_TIME = 120.0
STAND_SETTLE_TIME = 60.0
STAND_RELEASE_TIME = 120.0
#: the cylinder pressure at which a release counts as done, Pa gauge (UIC 540)
RELEASED = 0.4e5


@dataclass(frozen=True)
class Check:
    """One line of a brake test: what was measured (its unit), the window (low, high;
    None where the norm gives no bound) and its source."""

    test: str        # "stand" or "train"
    name: str
    value: float
    unit: str        # "s", "Pa", "m/s"
    low: float | None
    high: float | None
    source: str

    @property
    def judged(self) -> bool:
        """True when a window bounds the value."""
        return self.low is not None or self.high is not None

    @property
    def passed(self) -> bool | None:
        """Whether the value lies in its window (None: no window)."""
        if not self.judged:
            return None
        return ((self.low is None or self.value >= self.low)
                and (self.high is None or self.value <= self.high))


def _window(table: dict, key: str):
    """``(low, high, source)`` of a ``[brake_test]`` entry ``{low, high, source}``
    (either bound may be absent)."""
    entry = table.get(key)
    if entry is None:
        return None, None, "no window in the preset"
    lo, hi = entry.get("low"), entry.get("high")
    return (None if lo is None else float(lo), None if hi is None else float(hi),
            str(entry.get("source", "")))


def stand_test(cv: np.ndarray, dv: np.ndarray, windows: dict) -> list[Check]:
    """The stand test of the valve rows ``cv``, ``dv`` (:data:`CV_PARAMS`, ``DV_PARAMS``)
    against ``windows`` (a preset's ``[brake_test]`` table)."""
    from ltdsim.engine.brakerig import ATM, I_CV, I_PIPE, run

    cyl = I_CV + bv.CV_CYL
    ts, ys = run((cv, dv), [(0.0, bv.H_RELEASE, 0.0), (1.0, bv.H_EMERGENCY, 0.0)],
                 1.0 + STAND_FILL_TIME)
    pc = ys[:, cyl] - ATM
    emergency = float(pc[-1])
    fill = float(ts[np.argmax(pc >= 0.95 * emergency)] - 1.0)
    full = dv[bv.DVP_FULL]
    t_release = 1.0 + STAND_SETTLE_TIME
    ts, ys = run((cv, dv), [(0.0, bv.H_RELEASE, 0.0), (1.0, bv.H_SERVICE, full),
                            (t_release, bv.H_RELEASE, 0.0)], t_release + STAND_RELEASE_TIME)
    pc = ys[:, cyl] - ATM
    held = ts <= t_release
    full_cyl = float(pc[held][-1])
    full_pipe = float(ys[held, I_PIPE][-1] - ATM)
    down = (ts > t_release) & (pc <= RELEASED)
    release = float(ts[np.argmax(down)] - t_release) if down.any() else math.inf
    out = []
    for name, key, value, unit in (
            ("fill to 95 % (emergency, from the handle)", "fill", fill, "s"),
            ("release to 0.4 bar (after a full service, from the handle)", "release",
             release, "s"),
            ("full-service cylinder", "full_service_cylinder", full_cyl, "Pa"),
            ("emergency cylinder", "emergency_cylinder", emergency, "Pa"),
            ("full-service pipe", "full_service_pipe", full_pipe, "Pa")):
        lo, hi, src = _window(windows, key)
        out.append(Check("stand", name, value, unit, lo, hi, src))
    return out


def front_train(valve, wagons: int, length: float, temperature: float):
    """The train test's scenario: a locomotive and ``wagons`` braked wagons of ``length``
    m (90 t, 40.5 kN cylinders: the train's mass does not enter the front), standing,
    the fluid brake with ``valve`` (a preset's name or a table) and air at
    ``temperature`` (K), the emergency from the lead at 1 s."""
    from ltdsim.scenario import Scenario

    t_end = 1.0 + 1.5 * (wagons * length) / 200.0 + 2.0  # s: a front at 200 m/s and more
    d = {
        "solver": {"method": "bs23", "t_end": t_end, "output_interval": 0.01,
                   "max_step": 0.05},
        "vehicles": [{"name": "loco", "mass": 9e4, "length": 19.0, "powered": True},
                     {"name": "wagon", "count": wagons, "mass": 9e4, "length": length,
                      "brake": {"cylinder_force": 40500.0, "rigging_ratio": 2.6,
                                "shoes": 8, "friction": 0.3}}],
        "couplers": {"default": {"model": "linear", "stiffness": 5e7, "damping": 2e5}},
        "traction": {"max_force": 3e5, "max_power": 6.4e6, "adhesion_mass": 9e4},
        "brake": {"model": "fluid", "fluid": {"valve": valve},
                  "air": {"temperature": temperature}},
        "driver": {"mode": "force", "force_profile": [[0.0, 0.0]],
                   "brake_commands": [{"time": 1.0, "handle": "emergency"}]},
        "initial": {"speed": 0.0},
    }
    return Scenario.from_dict(d, f"brake test train ({wagons} wagons, {temperature:.2f} K)")


def train_test(valve, windows: dict, progress=None) -> list[Check]:
    """The emergency front on the preset's test train (``windows["front_train"]``: wagons,
    length m) at each of ``windows["front_temperatures"]`` (K), against the
    ``front_speed`` window; ``progress(i, n)`` after each run."""
    from ltdsim.results.simulate import simulate
    from ltdsim.results.summary import fluid_brake_summary

    train = windows.get("front_train", {"wagons": 100, "length": 15.0})
    temps = windows.get("front_temperatures", [293.15])
    lo, hi, src = _window(windows, "front_speed")
    out = []
    for k, temp in enumerate(temps):
        sc = front_train(valve, int(train["wagons"]), float(train["length"]), float(temp))
        fs = fluid_brake_summary(simulate(sc))
        speed = float(fs["end_to_end_speed_m_s"]) if fs is not None else math.nan
        out.append(Check("train", f"emergency front end to end at {temp - 273.15:+.0f} C "
                                  f"({int(train['wagons'])} wagons of {train['length']:g} m)",
                         speed, "m/s", lo, hi, src))
        if progress is not None:
            progress(k + 1, len(temps))
    return out
