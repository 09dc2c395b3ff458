"""Keys that would have no effect on a run: the table of a subsystem the train does not
use (the fluid brake's under the lumped brake, the induction drive's under the traction
curve), a profile or controller of another driver mode, a recorded variable the train
does not produce, a value another key replaces, an adaptive step's setting under a fixed
step. Each is refused when the user wrote it (the file's keys, read from pydantic's
``model_fields_set``, or an override's), never for a value the schema filled in.
"""

from __future__ import annotations

from typing import Any

from ltdsim.variables import BY_NAME, DRIVE_SIGNALS

#: the fluid brake's recorded variables (the pipe, reservoirs, cylinders and exhaust)
_FLUID_RECORDS = ("bp", "ar", "bc", "ax")

#: lumped-brake keys the fluid brake does not read, and what it has in their place
_LUMPED_ONLY = {
    "propagation_speed": "the pipe's air flow carries the signal",
    "apply_time_constant": "the valves fill the cylinders",
    "release_time_constant": "the valves empty the cylinders",
    "minimum_level": "the driver's valve gives the minimum reduction",
    "emergency_level": "the valves' reservoirs set the emergency pressure",
}

#: a vehicle brake's keys only the fluid brake reads
_FLUID_ONLY = ("piston_area", "return_spring", "efficiency")

#: the adaptive method's keys (none of them read by a fixed-step method)
_ADAPTIVE_ONLY = ("rtol", "atol", "speed_atol", "hold_speed", "max_step", "air_max_step")

#: the driver's keys and the mode that reads each
_MODE_KEYS = {"speed_profile": "speed", "pid": "speed", "force_profile": "force",
              "notch_profile": "notch"}


def no_effect(sc) -> list[tuple[str, str]]:
    """``(dotted key, message)`` for every key of scenario ``sc`` that would have no
    effect on its run, whether given or not (:func:`written` picks the given ones): the
    message says why and what would read it."""
    out: list[tuple[str, str]] = []
    lumped = sc.brake.model == "lumped"
    if lumped:
        for key in ("fluid", "air"):
            out.append((f"brake.{key}", f"has no effect: the lumped brake (brake.model = "
                                        f"'lumped') has no brake pipe or valves; "
                                        f"[brake.{key}] is read by the fluid brake: set "
                                        "brake.model = 'fluid', or leave it out"))
        for i, v in enumerate(sc.vehicles):
            if v.brake is None:
                continue
            for key in _FLUID_ONLY:
                out.append((f"vehicles.{i}.brake.{key}",
                            f"has no effect (vehicle {i + 1} from the lead): the lumped "
                            "brake (brake.model = 'lumped') takes cylinder_force; "
                            f"{key} is read by the fluid brake (brake.model = 'fluid'): "
                            "set that, or leave it out"))
    else:
        for key, why in _LUMPED_ONLY.items():
            out.append((f"brake.{key}", f"has no effect under the fluid brake (brake.model "
                                        f"= 'fluid'), where {why}; {key} is read by the "
                                        "lumped brake (brake.model = 'lumped'): leave it "
                                        "out"))
        thermal = sc.brake.air.thermal
        if thermal != "wall":
            out.append(("brake.air.conductivity",
                        f"has no effect with brake.air.thermal = '{thermal}' (the pipe's "
                        + ("air is held at the wall's temperature" if thermal == "isothermal"
                           else "air exchanges no heat with the wall")
                        + "); conductivity is read with thermal = 'wall': set that, or "
                        "leave it out"))
    if not any((loco.drive or sc.traction.drive) == "induction" for loco in sc.consists()):
        for key in ("motor", "creep"):
            out.append((f"traction.{key}", "has no effect: no consist uses the induction "
                                           f"drive (traction.drive = '{sc.traction.drive}' "
                                           "and no [[locomotives]] drive = 'induction'); "
                                           f"[traction.{key}] is read by the induction "
                                           "drive: set traction.drive = 'induction' (or a "
                                           "consist's drive), or leave it out"))
    mode = sc.driver.mode
    for key, reader in _MODE_KEYS.items():
        if reader != mode and getattr(sc.driver, key) is not None:
            out.append((f"driver.{key}", f"has no effect in driver.mode = '{mode}'; {key} is "
                                         f"read in mode '{reader}': set driver.mode = "
                                         f"'{reader}', or leave it out"))
    if sc.initial.velocities is not None:
        out.append(("initial.speed", "has no effect: initial.velocities gives each vehicle's "
                                     "initial speed; give one of speed (the whole train) "
                                     "and velocities (one per vehicle)"))
    solver = sc.solver
    for key in _ADAPTIVE_ONLY:
        if not solver.adaptive:
            out.append((f"solver.{key}", f"has no effect with method = '{solver.method}' (a "
                                         f"fixed step); {key} is read by the adaptive "
                                         "method: set solver.method = 'bs23', or leave it "
                                         "out"))
        elif key == "air_max_step" and lumped:
            out.append(("solver.air_max_step", "has no effect with the lumped brake, which "
                                               "has no pneumatic states; air_max_step is "
                                               "read by bs23 with the fluid brake "
                                               "(brake.model = 'fluid'): leave it out"))
    if not solver.energy:
        out.append(("solver.energy_interval", "has no effect with solver.energy = false; "
                                              "energy_interval is read by the energy "
                                              "accounting: set solver.energy = true, or "
                                              "leave it out"))
    elif solver.adaptive:
        out.append(("solver.energy_interval", "has no effect with method = 'bs23', which "
                                              "integrates the powers as states at its own "
                                              "stages; energy_interval is read under a "
                                              "fixed step: leave it out"))
    missing = _not_produced(sc)
    if missing:
        names = ", ".join(f"{n} ({w})" for n, w in missing)
        out.append(("solver.record", f"names {names}, which this train does not produce: "
                                     f"leave {'it' if len(missing) == 1 else 'them'} out"))
    return out


def _not_produced(sc) -> list[tuple[str, str]]:
    """The names in ``solver.record`` the train does not produce, each with what would."""
    out = []
    fluid = sc.brake.model == "fluid"
    induction = any((loco.drive or sc.traction.drive) == "induction"
                    for loco in sc.consists())
    for name in sc.solver.record or ():
        source = BY_NAME[name].record
        if source in _FLUID_RECORDS and not fluid:
            out.append((name, "recorded by the fluid brake, brake.model = 'fluid'"))
        elif name in DRIVE_SIGNALS and not induction:
            out.append((name, "recorded by an induction drive, traction.drive = "
                              "'induction'"))
    return out


def written(model: Any, key: str) -> bool:
    """True when the dotted ``key`` of a validated ``model`` was given in its input (every
    table on the way in ``model_fields_set``), not filled in by the schema."""
    node = model
    for part in key.split("."):
        if isinstance(node, list):
            node = node[int(part)]
            continue
        if part not in node.model_fields_set:
            return False
        node = getattr(node, part)
    return True


def flat_keys(overrides: dict, prefix: str = "") -> list[str]:
    """The dotted keys ``overrides`` sets, a table's keys each on its own
    (``{"brake": {"fluid": {...}}}`` gives ``brake.fluid.valve``, ...)."""
    out = []
    for key, value in overrides.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, dict) and value:
            out.extend(flat_keys(value, dotted + "."))
        else:
            out.append(dotted)
    return out


def given_by(keys: list[str], key: str) -> bool:
    """True when one of the dotted ``keys`` sets ``key`` or a key inside it."""
    return any(k == key or k.startswith(key + ".") for k in keys)


def first_of_each(problems: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """``problems`` with a vehicle's key reported for the first vehicle only (a group of
    ``count`` vehicles gives the same key on each)."""
    seen, out = set(), []
    for key, msg in problems:
        parts = key.split(".")
        kind = ".".join(parts[2:]) if parts[0] == "vehicles" else key
        if kind not in seen:
            seen.add(kind)
            out.append((key, msg))
    return out
