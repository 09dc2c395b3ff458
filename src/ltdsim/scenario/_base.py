"""What every table of the schema shares: strict models (no type coercion, unknown keys
refused, no NaN or inf), table rows read as tuples, piecewise tables checked, the sanity
bounds of masses and lengths, and the dotted-key setter of overrides.
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
)

from ltdsim.errors import ScenarioError



# Physical sanity bounds used in validation (documented in docs/scenario.md).
MAX_MASS = 1.0e6  # kg, one vehicle


MAX_LENGTH = 100.0  # m, one vehicle


MAX_VEHICLES = 20_000


#: m: the largest distance from chainage 0 a position of a track table may lie
#: (docs/scenario.md, "Positions along the line"): 10,000 km, longer than any railway
#: line (the Trans-Siberian is 9,289 km). A position beyond it (1e300 m, say) is no place
#: on a line, and its differences lose every metre to rounding.
MAX_CHAINAGE = 1.0e7


class _Strict(BaseModel):
    # strict types: a number must be a TOML number (integer or float; never a string or a
    # boolean), an integer a TOML integer, a flag a TOML boolean, a name a string, so that
    # ``mass = true`` or ``dt = "1e-4"`` is refused instead of read as 1 kg or 1e-4 s
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True,
                              strict=True)


def _array_to_tuple(v):
    """TOML (and JSON) give arrays as lists; a table row is validated as a tuple."""
    return tuple(v) if isinstance(v, list) else v


Pair = Annotated[tuple[float, float], BeforeValidator(_array_to_tuple)]


Triple = Annotated[tuple[float, float, float], BeforeValidator(_array_to_tuple)]


Points = list[Pair]


def _check_table(points: Points, what: str, ok, allowed: str) -> Points:
    """A piecewise table: at least one point, first column strictly increasing, every
    value in the second column passing ``ok`` (described by ``allowed``)."""
    if len(points) == 0:
        raise ValueError("needs at least one [x, y] point")
    xs = [p[0] for p in points]
    if any(b <= a for a, b in zip(xs, xs[1:])):
        raise ValueError(f"the first column ({what}) must be strictly increasing, got {xs}")
    bad = [p[1] for p in points if not ok(p[1])]
    if bad:
        raise ValueError(f"the second column must be {allowed}, got {bad}")
    return points


def _check_chainages(xs, what: str) -> None:
    """Refuse a position of a track table (``what``: the column, "start positions, m")
    farther than :data:`MAX_CHAINAGE` from chainage 0, in one line naming the range."""
    bad = [x for x in xs if not abs(x) <= MAX_CHAINAGE]
    if bad:
        raise ValueError(f"the first column ({what}) must lie within +-{MAX_CHAINAGE:g} m "
                         f"of chainage 0 ({MAX_CHAINAGE / 1e3:,.0f} km), got {bad[0]:g} m")


def _show(value: float, unit: str) -> str:
    """A value with its unit as a message writes it; a pressure (Pa) also in bar."""
    if unit == "Pa" or unit.startswith("Pa "):  # (Pa gauge: "5e+05 Pa (5 bar) gauge")
        return f"{value:g} Pa ({value / 1e5:g} bar){unit[2:]}"
    return f"{value:g}" if unit == "-" else f"{value:g} {unit}"


def quantity(lo: float, hi: float, unit: str, *, zero: bool = False, why: str = ""):
    """A number (strict: a TOML integer or float) within ``[lo, hi]`` in ``unit``, or with
    ``zero`` also exactly 0 (none: no such volume, orifice or stage). A value outside is
    refused in one line naming the range with its unit and ``why`` (the range's
    reading or its source)."""
    def check(value: float) -> float:
        if (zero and value == 0.0) or lo <= value <= hi:
            return value
        rng = f"{_show(lo, unit)} to {_show(hi, unit)}" + (" (or 0: none)" if zero else "")
        raise ValueError(f"must be within {rng}, got {_show(value, unit)}"
                         + (f" ({why})" if why else ""))
    return Annotated[float, AfterValidator(check)]


def _set_dotted(data: dict, key: str, value: Any, source: str) -> None:
    parts = key.split(".")
    node: Any = data
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        where = ".".join(parts[: depth + 1])
        if isinstance(node, list):
            if not part.lstrip("-").isdigit():
                raise ScenarioError(source, [(key, f"{where!r}: expected an index 0-{len(node) - 1}")])
            idx = int(part)
            if not 0 <= idx < len(node):
                raise ScenarioError(source, [(key, f"index {idx} out of range 0-{len(node) - 1}")])
            if last:
                node[idx] = value
            else:
                node = node[idx]
        elif isinstance(node, dict):
            if last:
                node[part] = value  # unknown keys are caught by validation
            else:
                if node.get(part) is None:
                    node[part] = {}
                node = node[part]
        else:
            raise ScenarioError(source, [(key, f"{'.'.join(parts[:depth])!r} is a value, not a table")])
