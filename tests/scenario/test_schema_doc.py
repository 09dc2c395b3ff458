"""docs/scenario.md against the scenario schema.

The key tables of docs/scenario.md are generated (ltdsim.scenario.doc). These tests check
that the file is what the generator writes now (so it cannot drift from the code), that
every quantity's description carries a unit, and, against an independent reading of the
schema (pydantic's JSON schema, walked here without the generator), that every field of
every reachable model has its row with its unit, range, choices, default and whether it
is required.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Literal

import pytest
from pydantic import BaseModel, ConfigDict, Field

from ltdsim.scenario import doc as schemadoc
from ltdsim.scenario import Scenario

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenario.md"


# ------------------------------------------------- an independent reading of the schema
def _resolve(node: dict, defs: dict) -> dict:
    while "$ref" in node:
        target = defs[node["$ref"].rsplit("/", 1)[-1]]
        node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
    return node


def _options(spec: dict, defs: dict) -> list[dict]:
    """The non-null alternatives of a property."""
    spec = _resolve(spec, defs)
    opts = spec.get("anyOf") or spec.get("oneOf") or [spec]
    return [_resolve(o, defs) for o in opts if o.get("type") != "null"]


def _constant_key(members: list[dict]) -> str | None:
    """The property that at least two members of a union fix to a constant, if any."""
    for name in {n for m in members for n in m["properties"]}:
        if sum("const" in m["properties"].get(name, {}) for m in members) >= 2:
            return name
    return None


def leaves(model: type[BaseModel]) -> list[dict]:
    """Every leaf field reachable from ``model``'s JSON schema: dotted path (``<i>`` for
    an index), the discriminator value of the union member that holds it (None outside
    one), whether it is required, its description, its alternatives and its default."""
    js = model.model_json_schema()
    defs = js.get("$defs", {})
    out: list[dict] = []

    def walk(node, path, variant, skip=None):
        node = _resolve(node, defs)
        required = set(node.get("required", []))
        for name, spec in node.get("properties", {}).items():
            if name == skip:
                continue
            p = f"{path}.{name}" if path else name
            spec = _resolve(spec, defs)
            opts = [spec] if "discriminator" in spec else _options(spec, defs)
            tables = [o for o in opts if "properties" in o]
            key = None
            if len(tables) > 1:
                # a union of tables told apart by a function: the members are known by the
                # key each fixes to a constant; a member that fixes none (a stand-in that
                # refuses unknown values) has no keys of its own to document
                key = _constant_key(tables)
                if key is not None:
                    opts = [o for o in opts if "const" in o.get("properties", {}).get(key, {})]
            nested = False
            for o in opts:
                items = _resolve(o.get("items", {}), defs) if o.get("type") == "array" else None
                target, sub = (items, f"{p}.<i>") if items is not None else (o, p)
                members = target.get("oneOf") or target.get("anyOf")
                disc = (target.get("discriminator") or {}).get("propertyName")
                if members and disc:
                    for m in members:
                        m = _resolve(m, defs)
                        const = m["properties"][disc].get("const") or \
                            m["properties"][disc]["enum"][0]
                        walk(m, sub, const, skip=disc)
                    nested = True
                elif members and all("properties" in _resolve(m, defs) for m in members):
                    for m in members:  # a union of tables without a discriminator
                        walk(m, sub, _resolve(m, defs)["title"])
                    nested = True
                elif "properties" in target and key is not None:
                    walk(target, sub, target["properties"][key]["const"], skip=key)
                    nested = True
                elif "properties" in target:
                    plain = sum("properties" in x for x in opts) > 1  # a union of tables
                    walk(target, sub, target["title"] if plain else None)
                    nested = True
            if not nested:
                out.append({"path": p, "variant": variant, "required": name in required,
                            "description": spec.get("description", ""), "options": opts,
                            "default": spec.get("default", "<none>")})

    walk(js, "", None)
    return out


# ---------------------------------------------------------------- reading the Markdown
def rows(text: str) -> dict[tuple[str, str | None], dict]:
    """The key tables of a generated document: (path, variant) -> cells."""
    out = {}
    variant = None
    inside = False
    for line in text.splitlines():
        if line.startswith(("<!-- BEGIN schema ", "<!-- END schema ")):
            inside = line.startswith("<!-- BEGIN")
            continue
        if not inside:
            continue
        if line.startswith(("`[", "Top-level keys")):
            m = re.search(r'with `\w+ = "([^"]+)"`|as `(\w+)`', line)
            variant = (m.group(1) or m.group(2)) if m else None
        if not line.startswith("| `"):
            continue
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        key, kind, unit, default, allowed, meaning = cells
        out[(key.strip("`"), variant)] = {"kind": kind, "unit": unit.strip("`"),
                                          "default": default, "allowed": allowed,
                                          "meaning": meaning}
    return out


_PLAIN = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")


def _plain_unit(cell: str) -> str:
    """``m/s²`` back to ``m/s^2`` as descriptions write it."""
    return re.sub(r"([⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)", lambda m: "^" + m.group(1).translate(_PLAIN), cell)


def _numbers(opt: dict) -> list[dict]:
    """The number (or integer) schemas inside one alternative (items included)."""
    if opt.get("type") in ("number", "integer"):
        return [opt]
    if opt.get("type") == "array" and isinstance(opt.get("items"), dict):
        return _numbers(opt["items"])
    return []


def _has_number(node: dict) -> bool:
    """Whether a value of this schema holds a real number (a quantity, needing a unit)."""
    if node.get("type") == "number":
        return True
    parts = node.get("prefixItems", []) + node.get("anyOf", []) + node.get("oneOf", [])
    if isinstance(node.get("items"), dict):
        parts.append(node["items"])
    return any(_has_number(p) for p in parts)


def problems(model: type[BaseModel], text: str) -> list[str]:
    """What the document ``text`` gets wrong or leaves out about ``model``'s fields."""
    table = rows(text)
    bad = []
    for leaf in leaves(model):
        where = leaf["path"] + (f" (model = {leaf['variant']!r})" if leaf["variant"] else "")
        row = table.get((leaf["path"], leaf["variant"]))
        if row is None:
            bad.append(f"{where}: no row")
            continue
        desc, unit = leaf["description"], _plain_unit(row["unit"])
        quantity = any(_has_number(o) for o in leaf["options"])
        if quantity:
            if unit in ("", "–"):
                if not re.search(r", -(\s*\(.*\))?$", desc):
                    bad.append(f"{where}: no unit (description {desc!r})")
            else:
                for u in re.findall(r"[^\[\],]+", unit.replace(" or ", ",")):
                    u = u.strip()
                    if u != "-" and u not in desc:
                        bad.append(f"{where}: unit {u!r} is not the description's ({desc!r})")
        for o in leaf["options"]:
            for num in _numbers(o):
                for key, fmt in (("minimum", "[{}|≥ {}"), ("exclusiveMinimum", "({}|> {}"),
                                 ("maximum", "{}]|≤ {}"), ("exclusiveMaximum", "{})|< {}")):
                    if key in num:
                        v = schemadoc.fmt_number(num[key] if num.get("type") == "number"
                                                 else int(num[key]))
                        if not any(f.format(v, v) in row["allowed"]
                                   for f in fmt.split("|")):
                            bad.append(f"{where}: {key} {v} not in allowed "
                                       f"{row['allowed']!r}")
            for value in o.get("enum", []) + ([o["const"]] if "const" in o else []):
                if f'"{value}"' not in row["allowed"]:
                    bad.append(f"{where}: choice {value!r} not in allowed {row['allowed']!r}")
            if 1 in (o.get("minLength"), o.get("minItems")) and \
                    "non-empty" not in row["allowed"]:
                bad.append(f"{where}: 'non-empty' not in allowed {row['allowed']!r}")
        if leaf["required"] != (row["default"] == "required"):
            bad.append(f"{where}: required is {leaf['required']}, the row says "
                       f"{row['default']!r}")
        d = leaf["default"]
        if not leaf["required"] and d != "<none>":
            if d is None or d == [] or d == {}:
                want = "none"
            elif isinstance(d, bool):
                want = "true" if d else "false"
            elif isinstance(d, (int, float)):
                want = schemadoc.fmt_number(d)
            elif isinstance(d, str):
                want = f'"{d}"'
            else:
                want = None  # arrays of points: shown as TOML, checked by the generator test
            if want is not None and want not in row["default"]:
                bad.append(f"{where}: default {want} not in {row['default']!r}")
    return bad


# ------------------------------------------------------------------------------ tests
def test_doc_is_generated_from_the_schema():
    text = DOC.read_text(encoding="utf-8")
    assert schemadoc.render(text) == text, (
        "docs/scenario.md differs from the schema: run `python -m ltdsim.scenario.doc` "
        "and commit the result")


def test_every_field_of_every_model_has_its_row_unit_and_range():
    text = DOC.read_text(encoding="utf-8")
    found = leaves(Scenario)
    assert len(found) > 100  # the walk reaches the nested tables, not just the top level
    bad = problems(Scenario, text)
    assert not bad, "docs/scenario.md against the schema:\n" + "\n".join(bad)


def test_every_quantity_has_a_unit():
    missing = schemadoc.missing_units()
    assert missing == [], ("no unit in the description of " + ", ".join(missing) +
                           " (write 'meaning, UNIT', '-' for dimensionless; see "
                           "ltdsim.scenario.doc)")


# ------------------------------------------------ the generator on models of its own
class _S(BaseModel):
    model_config = ConfigDict(extra="forbid")


class _Linear(_S):
    """A spring."""

    model: Literal["linear"]
    stiffness: float = Field(gt=0.0, le=1e12, description="spring rate, N/m")
    slack: float = Field(0.0, ge=0.0, le=1.0, description="free play, m")


class _Tabled(_S):
    model: Literal["tabled"]
    loading: list[tuple[float, float]] = Field(
        description="[deflection m, force N] loading curve")
    decay: float = Field(0.5, ge=0.0, lt=100.0, description="friction decay, s/m")


class _Gears(_S):
    default: Annotated[_Linear | _Tabled, Field(discriminator="model")]
    override: list[Annotated[_Linear | _Tabled, Field(discriminator="model")]] = []


class _Rail(_S):
    """Rail of one kind."""

    mass: float = Field(60.0, gt=0.0, description="mass per length, kg/m")


class _Slab(_S):
    thickness: float = Field(0.2, gt=0.0, le=1.0, description="slab thickness, m")


class _Toy(_S):
    name: str = Field("toy", description="label")
    track: _Rail | _Slab | None = Field(None, description="what the train runs on")
    speed: float = Field(0.0, ge=0.0, le=150.0, description="initial speed, m/s")
    mode: Literal["a", "b"] = Field("a", description="which way")
    gears: _Gears


class _Unitless(_S):
    ratio: float = Field(1.0, gt=0.0, description="a ratio with no unit given")
    count: int = Field(1, ge=1, description="how many")
    curve: list[tuple[float, float]] = Field(default_factory=list,
                                             description="[time s, level] points")


_TOY_DOC = """# Toy

<!-- BEGIN schema top -->
<!-- END schema top -->

<!-- BEGIN schema rest -->
<!-- END schema rest -->
"""


def test_discriminated_union_gives_a_table_per_model_with_its_keys():
    text = schemadoc.render(_TOY_DOC, _Toy)
    assert problems(_Toy, text) == []
    table = rows(text)
    # each member's table lists its own keys, and only those
    assert ("gears.default.stiffness", "linear") in table
    assert ("gears.default.stiffness", "tabled") not in table
    assert ("gears.default.decay", "tabled") in table
    assert ("gears.override.<i>.loading", "tabled") in table
    assert ("track.mass", "_Rail") in table and ("track.thickness", "_Slab") in table
    assert table[("gears.default.loading", "tabled")]["unit"] == "[m, N]"
    assert table[("gears.default.decay", "tabled")]["allowed"] == "[0, 100)"
    assert 'with `model = "linear"`' in text and 'with `model = "tabled"`' in text
    # one heading per top-level table in 'rest', also for a union's members
    assert text.count("### `[gears]`") == 1 and text.count("### `[track]`") == 1
    assert "`[track]` as `_Rail` (optional). Rail of one kind." in text
    assert schemadoc.render(text, _Toy) == text  # rewriting is idempotent
    # the independent check notices a dropped row
    broken = "\n".join(ln for ln in text.splitlines() if "`gears.default.decay`" not in ln)
    assert problems(_Toy, broken) == ["gears.default.decay (model = 'tabled'): no row"]


def test_a_quantity_without_a_unit_is_named():
    missing = schemadoc.missing_units(_Unitless)
    assert missing == ["ratio", "curve"]  # count is a whole number: no unit needed


@pytest.mark.parametrize("desc, unit", [
    ("end time, s", "s"),
    ("first-order lag of the force, s (0 = none)", "s"),
    ("bs23: relative tolerance (not applied to positions, whose size is arbitrary), -", "-"),
    ("term proportional to the square of speed, N s^2/m^2", "N s^2/m^2"),
    ("proportional gain (m/s^2 of demand per m/s of error), 1/s", "1/s"),
    ("absolute tolerance, m and m/s (force states: x 1e6 N/m)", "m and m/s"),
    ("wedge angles too steep, see the text", None),
    ("a ratio with no unit given", None),
])
def test_unit_is_the_last_part_of_the_description(desc, unit):
    assert schemadoc.split_unit(desc)[1] == unit


def test_blocks_that_name_no_table_are_refused():
    with pytest.raises(ValueError, match="nonsense: no such section"):
        schemadoc.render("<!-- BEGIN schema nonsense -->\n<!-- END schema nonsense -->\n",
                         _Toy)
    with pytest.raises(ValueError, match="no 'rest' block"):
        schemadoc.render("<!-- BEGIN schema top -->\n<!-- END schema top -->\n", _Toy)
